// SPDX-License-Identifier: Apache-2.0
#include "host/cycle_log.h"

#include "mcap/reader.h"
#include "mcap/writer.h"
#include "rt/clock.h"
#include "rtm/cdr.h"
#include "rtm/log.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/logger.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <stdexcept>

namespace rtm {

namespace {

constexpr std::size_t kEvents = std::size_t{1} << 14;
constexpr const char* kMetadata = "rtm.cycle_log";
constexpr const char* kEndMetadata = "rtm.cycle_log.end";
constexpr const char* kCyclesTopic = "cycles";

// An event's kind: a group's edge, or what a tap told (TapEvent, in its order, from `read`).
enum Kind : std::uint8_t { start, cycle_begins, stop, read, read_many, write_datum, lost_datum };
static_assert(read + static_cast<int>(TapEvent::read_many) == read_many &&
              read + static_cast<int>(TapEvent::write) == write_datum &&
              read + static_cast<int>(TapEvent::lost) == lost_datum);
constexpr const char* kGroupNames[] = {"start", "cycle", "stop"};
constexpr int kMany = 3;  // a read_many in a group's reads: [port, 3, count]

// Each parameter's value as set_parameter takes it (read as the servant does: under its lock).
std::map<std::string, std::string> parameter_values(ComponentServant& servant) {
  std::map<std::string, std::string> values;
  RTM::ParameterList_var list = servant.parameters();
  for (CORBA::ULong i = 0; i < list->length(); ++i) values[list[i].name.in()] = list[i].value.in();
  return values;
}

void untap(Component& component) {
  for (InPortBase* port : component.in_ports()) port->untap();
  for (OutPortBase* port : component.out_ports()) port->untap();
}

}  // namespace

// ============================ the log ==================================

CycleLog::CycleLog(ComponentServant& servant, const std::string& path, CycleLogOptions options)
    : servant_(servant), ring_(kEvents), options_(options) {
  if (options_.slots_per_port == 0) throw std::invalid_argument("a cycle log needs at least one slot per port");
  Component& component = servant.component();
  std::uint16_t key = 0;
  const auto words = [](const PortInfo& info, bool units) {
    std::string out;
    for (std::size_t i = 0; i < info.elements.size(); ++i)  // as rtm record writes them
      out += (i == 0 ? "" : ",") + (units ? info.elements[i].unit : info.elements[i].name);
    return out;
  };
  std::vector<std::pair<std::string, std::string>> described;
  for (InPortBase* port : component.in_ports()) {
    ports_.push_back({port->full_name(), true, port->tap(this, key++, options_.slots_per_port), 0});
    described.emplace_back(words(port->info(), false), words(port->info(), true));
  }
  for (OutPortBase* port : component.out_ports()) {
    ports_.push_back({port->full_name(), false, port->tap(this, key++, options_.slots_per_port), 0});
    described.emplace_back(words(port->info(), false), words(port->info(), true));
  }
  try {
    mcap::WriterOptions options;
    options.profile = "rtm-cycles";
    writer_ = std::make_unique<mcap::Writer>(path, options);
    mcap::KeyValues meta{{"component", component.name()}, {"kind", component.kind()}, {"format", "1"}};
    for (const auto& [name, value] : parameter_values(servant)) meta["parameter." + name] = value;
    writer_->add_metadata(kMetadata, meta);
    std::map<std::string, std::uint16_t> schemas;
    for (std::size_t k = 0; k < ports_.size(); ++k) {
      Port& p = ports_[k];
      const std::string type = type_name(p.tap->type_code());
      if (!schemas.contains(type)) schemas[type] = writer_->add_schema(type, "omgidl", idl_text(p.tap->type_code()));
      const auto dot = p.name.find('.');
      p.channel = writer_->add_channel(schemas[type], p.name, "cdr",
                                       {{"type", type},
                                        {"component", p.name.substr(0, dot)},
                                        {"port", p.name.substr(dot + 1)},
                                        {"direction", p.in ? "in" : "out"},
                                        {"elements", described[k].first},
                                        {"units", described[k].second},
                                        {"log_time", "the due time of the cycle that read or wrote it (CLOCK_MONOTONIC)"},
                                        {"typecode", type_code_text(p.tap->type_code())}});
    }
    cycles_channel_ = writer_->add_channel(0, kCyclesTopic, "json", {{"content", "each start, cycle and stop"}});
  } catch (...) {
    untap(component);
    throw;
  }
  servant.observe_cycles(this);
  thread_ = std::thread([this] { run(); });
}

CycleLog::~CycleLog() {
  servant_.observe_cycles(nullptr);
  {
    std::lock_guard lock(flush_mu_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  Component& component = servant_.component();
  untap(component);
  try {
    drain();
    end_group();
    mcap::KeyValues end{{"lost", std::to_string(lost_.load())}};
    for (const auto& [name, value] : parameter_values(servant_)) end["parameter." + name] = value;
    writer_->add_metadata(kEndMetadata, end);
    writer_->close();
    if (lost_.load() > 0)
      log().warn("{}: the cycle log lost {} events or data (its writer fell behind): those cycles cannot be replayed",
                 component.name(), lost_.load());
  } catch (const std::exception& e) {
    log().error("{}: the cycle log could not be finished: {}", component.name(), e.what());
  }
}

void CycleLog::push(const Event& e) noexcept {
  if (head_ - taken_.load(std::memory_order_acquire) >= ring_.size()) {
    lost_.fetch_add(1, std::memory_order_relaxed);
    ++lost_unpushed_;
    return;
  }
  Event& slot = ring_[head_ % ring_.size()];
  slot = e;
  slot.lost_before = lost_unpushed_;
  lost_unpushed_ = 0;
  ++head_;
  published_.store(head_, std::memory_order_release);
}

void CycleLog::tapped(std::uint16_t port, TapEvent event, ReadResult result, std::uint32_t slot,
                      std::uint32_t count) noexcept {
  Event e;
  e.kind = static_cast<std::uint8_t>(read + static_cast<std::uint8_t>(event));
  e.result = static_cast<std::uint8_t>(result);
  e.port = port;
  e.slot = slot;
  e.count = count;
  if (event == TapEvent::lost) lost_.fetch_add(1, std::memory_order_relaxed);
  push(e);
}

void CycleLog::starting() noexcept { push_edge(start); }

void CycleLog::cycle(const CycleContext& ctx) noexcept {
  Event e;
  e.kind = cycle_begins;
  e.cycle = ctx.cycle;
  e.deadline_ns = ctx.deadline_ns;
  e.wake_ns = ctx.wake_ns;
  e.period_ns = ctx.period_ns;
  push(e);
}

void CycleLog::stopping() noexcept { push_edge(stop); }

void CycleLog::push_edge(std::uint8_t kind) noexcept {  // a start or a stop, timed now
  Event e;
  e.kind = kind;
  e.deadline_ns = e.wake_ns = monotonic_ns();
  push(e);
}

void CycleLog::run() {
  std::unique_lock lock(flush_mu_);
  while (!stop_) {
    wake_.wait_for(lock, options_.write_every, [this] { return stop_; });
    try {
      drain_locked();
    } catch (const std::exception& e) {
      if (error_.empty()) log().error("{}: the cycle log stopped writing: {}", servant_.component().name(), e.what());
      error_ = e.what();
    }
  }
}

void CycleLog::flush() {
  std::lock_guard lock(flush_mu_);
  drain_locked();
  writer_->flush();
}

void CycleLog::drain() {
  std::lock_guard lock(flush_mu_);
  drain_locked();
}

void CycleLog::drain_locked() {
  const std::uint64_t end = published_.load(std::memory_order_acquire);
  for (std::uint64_t i = taken_.load(std::memory_order_relaxed); i < end; ++i) {
    const Event& e = ring_[i % ring_.size()];
    if (error_.empty()) write(e);  // after an error the cycle thread goes on; what it logs is dropped
    // A datum event's slots go back to its tap, written out or not.
    if (e.kind >= read && e.kind != lost_datum && e.port < ports_.size()) ports_[e.port].tap->release(e.count);
    taken_.store(i + 1, std::memory_order_release);
  }
}

void CycleLog::write(const Event& e) {
  group_lost_ += e.lost_before;
  if (e.kind <= stop) {
    end_group();
    group_open_ = true;
    group_kind_ = e.kind;
    group_cycle_ = e.cycle;
    group_deadline_ns_ = e.deadline_ns;
    group_wake_ns_ = e.wake_ns;
    group_period_ns_ = e.period_ns;
    return;
  }
  if (e.kind == lost_datum) {
    group_lost_ += std::max<std::uint32_t>(e.count, 1);
    return;
  }
  // A port used before the first start is no part of a cycle: not written.
  if (!group_open_ || e.port >= ports_.size()) return;
  Port& port = ports_[e.port];
  std::string& list = e.kind == write_datum ? group_writes_ : group_reads_;
  const char* comma = list.empty() ? "" : ",";
  if (e.kind == read) fmt::format_to(std::back_inserter(list), "{}[{},{}]", comma, e.port, e.result);
  else if (e.kind == read_many) fmt::format_to(std::back_inserter(list), "{}[{},{},{}]", comma, e.port, kMany, e.count);
  else fmt::format_to(std::back_inserter(list), "{}{}", comma, e.port);
  const auto time = static_cast<std::uint64_t>(group_deadline_ns_);
  for (std::uint32_t k = 0; k < e.count; ++k) {
    port.tap->encode((e.slot + k) % options_.slots_per_port, scratch_);
    writer_->write(port.channel, group_number_, time, time, scratch_);
  }
}

void CycleLog::end_group() {
  if (!group_open_) return;
  const std::string json = fmt::format(
      R"({{"group":"{}","number":{},"cycle":{},"deadline_ns":{},"wake_ns":{},"period_ns":{},"reads":[{}],"writes":[{}],"lost":{}}})",
      kGroupNames[group_kind_], group_number_, group_cycle_, group_deadline_ns_, group_wake_ns_, group_period_ns_,
      group_reads_, group_writes_, group_lost_);
  const auto time = static_cast<std::uint64_t>(group_deadline_ns_);
  writer_->write(cycles_channel_, group_number_, time, time,
                 std::span(reinterpret_cast<const std::uint8_t*>(json.data()), json.size()));
  group_open_ = false;
  ++group_number_;
  group_reads_.clear();
  group_writes_.clear();
  group_lost_ = 0;
}

// ============================ the replay ===============================

namespace {

struct Group {
  int kind = 0;  // Kind: start, cycle_begins, stop
  std::uint32_t number = 0;
  CycleContext ctx;
  struct Read {
    std::uint16_t port = 0;
    int result = 0;  // ReadResult, or kMany
    std::uint32_t count = 0;
  };
  std::vector<Read> reads;  // its writes are found by group number on the out ports' channels
  std::uint64_t lost = 0;
};

Group parse_group(const mcap::Message& m) {
  const std::string text(m.data.begin(), m.data.end());
  const auto fail = [&](const std::string& why) {
    return std::runtime_error(fmt::format("group {} of the log is malformed: {}", m.sequence, why));
  };
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw fail("not a JSON object");
  try {
    Group g;
    const std::string name = j.at("group").get<std::string>();
    if (name == "start") g.kind = start;
    else if (name == "cycle") g.kind = cycle_begins;
    else if (name == "stop") g.kind = stop;
    else throw fail("group \"" + name + "\" is none of start, cycle, stop");
    g.number = j.at("number").get<std::uint32_t>();
    g.ctx.cycle = j.at("cycle").get<std::uint64_t>();
    g.ctx.deadline_ns = j.at("deadline_ns").get<std::int64_t>();
    g.ctx.wake_ns = j.at("wake_ns").get<std::int64_t>();
    g.ctx.period_ns = j.at("period_ns").get<std::int64_t>();
    g.lost = j.at("lost").get<std::uint64_t>();
    for (const auto& r : j.at("reads")) {
      Group::Read read;
      read.port = r.at(0).get<std::uint16_t>();
      read.result = r.at(1).get<int>();
      if (read.result == kMany) read.count = r.at(2).get<std::uint32_t>();
      else if (read.result < 0 || read.result > 2) throw fail("a read result out of range");
      g.reads.push_back(read);
    }
    return g;
  } catch (const nlohmann::json::exception& e) {
    throw fail(e.what());
  }
}

std::map<std::string, std::string> prefixed(const mcap::KeyValues& values, const std::string& prefix) {
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : values)
    if (key.starts_with(prefix)) out[key.substr(prefix.size())] = value;
  return out;
}

}  // namespace

namespace {

CycleLogInfo info_of(const mcap::Reader& reader, const std::string& log) {
  CycleLogInfo info;
  bool found = false;
  for (const auto& m : reader.metadata()) {
    if (m.name == kMetadata) {
      found = true;
      const auto component = m.values.find("component");
      const auto kind = m.values.find("kind");
      if (component == m.values.end() || kind == m.values.end())
        throw std::runtime_error(log + ": its cycle-log metadata names no component");
      info.component = component->second;
      info.kind = kind->second;
      info.parameters = prefixed(m.values, "parameter.");
    } else if (m.name == kEndMetadata) {
      info.parameters_at_end = prefixed(m.values, "parameter.");
      const auto lost = m.values.find("lost");
      if (lost == m.values.end()) continue;
      const auto& text = lost->second;
      const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), info.lost);
      if (error != std::errc() || end != text.data() + text.size())
        throw std::runtime_error(log + ": its end says it lost '" + text + "': not a count");
    }
  }
  if (!found) throw std::runtime_error(log + ": not a cycle log (no " + std::string(kMetadata) + " metadata)");
  return info;
}

}  // namespace

CycleLogInfo read_cycle_log_info(const std::string& log) { return info_of(mcap::Reader(log), log); }

namespace {

// One of the log's ports, and the component's tap in its place.
struct Tapped {
  std::string name;
  bool in = false;
  const mcap::Channel* channel = nullptr;
  PortTap* tap = nullptr;
  std::vector<const mcap::Message*> messages;  // by group, each group's in file order
  std::size_t next = 0;
  std::uint16_t output_channel = 0;
};

// A replay: the log read whole, the component built afresh with no activity, the log's groups
// stepped through one by one.
class Replay {
 public:
  Replay(std::unique_ptr<Component> component, const std::string& log, const ReplayOptions& options)
      : log_(log), options_(options), reader_(log), info_(info_of(reader_, log)) {
    result_.component = info_.component;
    if (component->name() != info_.component)
      throw std::runtime_error(fmt::format("the log is {}'s, the component built is {}", info_.component, component->name()));
    read_ports(*component);
    servant_ = std::make_unique<ComponentServant>(std::move(component), ExternalTick{});
    tap_ports();
    read_groups();
  }
  ~Replay() {
    if (servant_) untap(servant_->component());
  }
  Replay(const Replay&) = delete;
  Replay& operator=(const Replay&) = delete;

  ReplayResult run() {
    open_output();
    set_parameters();
    const CycleFunction step = servant_->cycle_function();
    bool have_span = false;
    std::int64_t first_ns = 0, last_ns = 0;
    const auto started = std::chrono::steady_clock::now();
    for (const Group& g : groups_) {
      answer_reads(g);
      if (g.kind == start) {
        servant_->on();
      } else if (g.kind == stop) {
        servant_->off();
      } else {
        ++result_.cycles;
        if (!have_span) first_ns = g.ctx.deadline_ns;
        have_span = true;
        last_ns = g.ctx.deadline_ns;
        if (!step(g.ctx))
          throw std::runtime_error(
              fmt::format("{} failed in cycle {}: {}", info_.component, g.ctx.cycle, servant_->error_text()));
      }
      compare_writes(g);
    }
    if (servant_->current_state() == RTM::COMPONENT_ON) servant_->off();  // a log that ends with no stop
    result_.replay_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    result_.logged_span_ns = last_ns - first_ns;
    if (info_.lost > 0) result_.warnings.push_back(fmt::format("the log lost {} events or data while it was written", info_.lost));
    if (output_) output_->close();
    return std::move(result_);
  }

 private:
  // The log's channels, keyed as the log made them (in ports first, in order), against the
  // component's ports: the same names, directions and types.
  void read_ports(Component& component) {
    const mcap::Channel* cycles = reader_.channel(std::string(kCyclesTopic));
    if (cycles == nullptr) throw std::runtime_error(log_ + ": not a cycle log (no \"cycles\" channel)");
    cycles_id_ = cycles->id;
    for (const auto& c : reader_.channels()) {
      if (c.id == cycles_id_) continue;
      const auto dir = c.metadata.find("direction");
      if (dir == c.metadata.end() || !c.metadata.contains("typecode"))
        throw std::runtime_error(log_ + ": channel " + c.topic + " says no direction or type");
      by_channel_[c.id] = tapped_.size();
      tapped_.push_back({c.topic, dir->second == "in", &c, nullptr, {}, 0, 0});
    }
    const auto& ins = component.in_ports();
    const auto& outs = component.out_ports();
    if (tapped_.size() != ins.size() + outs.size())
      throw std::runtime_error(fmt::format("the log has {} ports, {} has {}", tapped_.size(), component.name(),
                                           ins.size() + outs.size()));
    for (std::size_t k = 0; k < tapped_.size(); ++k) {
      const bool in = k < ins.size();
      const std::string name = in ? ins[k]->full_name() : outs[k - ins.size()]->full_name();
      if (tapped_[k].name != name || tapped_[k].in != in)
        throw std::runtime_error(fmt::format("the log's port {} is the {} {}; this build has {} in its place", k,
                                             tapped_[k].in ? "InPort" : "OutPort", tapped_[k].name, name));
      const CORBA::TypeCode_var logged = type_code_from_text(tapped_[k].channel->metadata.at("typecode"));
      CORBA::TypeCode_ptr own = in ? ins[k]->type_code() : outs[k - ins.size()]->type_code();  // not ours to release
      if (!own->equivalent(logged))
        throw std::runtime_error(fmt::format("{} carries {} here, {} in the log", name, type_name(own), type_name(logged)));
      if (in) continue;
      result_.types[name] = CORBA::TypeCode::_duplicate(own);
      const auto elements = tapped_[k].channel->metadata.find("elements");
      if (elements != tapped_[k].channel->metadata.end()) result_.elements[name] = split_words(elements->second);
    }
  }

  void tap_ports() {
    Component& component = servant_->component();
    const auto& ins = component.in_ports();
    const auto& outs = component.out_ports();
    for (std::size_t k = 0; k < tapped_.size(); ++k) {
      const auto key = static_cast<std::uint16_t>(k);
      taps_.push_back(k < ins.size() ? ins[k]->tap(nullptr, key, 0) : outs[k - ins.size()]->tap(nullptr, key, 0));
      tapped_[k].tap = taps_.back().get();
    }
  }

  // Everything, grouped: a channel's messages keep file order within a group.
  void read_groups() {
    messages_ = reader_.messages();
    for (const auto& m : messages_) {
      if (m.channel_id == cycles_id_) {
        groups_.push_back(parse_group(m));
      } else if (const auto it = by_channel_.find(m.channel_id); it != by_channel_.end()) {
        tapped_[it->second].messages.push_back(&m);
      }
    }
    std::stable_sort(groups_.begin(), groups_.end(), [](const Group& a, const Group& b) { return a.number < b.number; });
    for (auto& t : tapped_)
      std::stable_sort(t.messages.begin(), t.messages.end(),
                       [](const mcap::Message* a, const mcap::Message* b) { return a->sequence < b->sequence; });
  }

  void open_output() {
    if (options_.output.empty()) return;
    output_ = std::make_unique<mcap::Writer>(options_.output);
    output_->add_metadata("rtm.replay", {{"component", info_.component}, {"log", log_}});
    std::map<std::string, std::uint16_t> schemas;
    for (auto& t : tapped_) {
      if (t.in) continue;
      const mcap::Schema* schema = reader_.schema(t.channel->schema_id);
      if (schema == nullptr) throw std::runtime_error(log_ + ": channel " + t.name + " has no schema");
      if (!schemas.contains(schema->name))
        schemas[schema->name] = output_->add_schema(schema->name, schema->encoding, schema->data);
      t.output_channel = output_->add_channel(schemas[schema->name], t.name, "cdr", t.channel->metadata);
    }
  }

  // The logged parameters, then the caller's; one fixed at build is checked, not set.
  void set_parameters() {
    const auto& declared = servant_->component().parameters();
    const auto built = parameter_values(*servant_);
    const auto set = [&](const std::string& name, const std::string& value, bool from_log) {
      const auto p = std::find_if(declared.begin(), declared.end(), [&](const Parameter& d) { return d.name == name; });
      if (p == declared.end()) {
        if (!from_log) throw std::runtime_error(info_.component + " has no parameter " + name);
        result_.warnings.push_back("the log has a parameter " + name + " this build does not: ignored");
        return;
      }
      if (p->access == ParameterAccess::fixed) {
        if (built.at(name) != value)
          throw std::runtime_error(fmt::format("{} is fixed at build: it was {} in the log, {} here (give it as the "
                                               "component's option)", name, value, built.at(name)));
        return;
      }
      try {
        servant_->set_parameter(name.c_str(), value.c_str());
      } catch (const RTM::ParameterRefused& e) {
        throw std::runtime_error(fmt::format("parameter {}={} refused: {}", name, value, e.reason.in()));
      }
    };
    const auto chosen = [&](const std::string& name) {
      return options_.parameters.contains(name) || options_.keep_built.contains(name);
    };
    for (const auto& [name, value] : info_.parameters)
      if (!chosen(name)) set(name, value, true);
    for (const auto& [name, value] : options_.parameters) set(name, value, false);
    for (const auto& [name, value] : info_.parameters_at_end) {
      const auto at_start = info_.parameters.find(name);
      if (at_start != info_.parameters.end() && at_start->second != value && !chosen(name))
        result_.warnings.push_back(fmt::format("the run changed {} while on ({} at the start, {} at the end): the "
                                               "replay uses {} throughout", name, at_start->second, value,
                                               at_start->second));
    }
  }

  // The group's reads answered, in order, from the log.
  void answer_reads(const Group& g) {
    const auto malformed = [&] {
      return std::runtime_error(fmt::format("group {} of the log names data it does not hold", g.number));
    };
    for (const auto& r : g.reads) {
      if (r.port >= tapped_.size() || !tapped_[r.port].in) throw malformed();
      Tapped& t = tapped_[r.port];
      const auto take = [&]() -> std::span<const std::uint8_t> {
        if (t.next >= t.messages.size() || t.messages[t.next]->sequence != g.number) throw malformed();
        return t.messages[t.next++]->data;
      };
      if (r.result == kMany) {
        std::vector<std::span<const std::uint8_t>> values;
        for (std::uint32_t k = 0; k < r.count; ++k) values.push_back(take());
        t.tap->answer_read_many(values);
      } else {
        const auto value = r.result == static_cast<int>(ReadResult::NewData) ? take() : std::span<const std::uint8_t>{};
        t.tap->answer_read(static_cast<ReadResult>(r.result), value);
      }
    }
  }

  // The group's writes against the logged ones (not for a group the log lost part of).
  void compare_writes(const Group& g) {
    for (auto& t : tapped_) {
      if (t.in) {
        result_.unanswered_reads += t.tap->unanswered();
        result_.unused_answers += t.tap->unused_answers();
        t.tap->clear();
        continue;
      }
      const auto replayed = t.tap->take_written();
      std::vector<const mcap::Message*> logged;
      while (t.next < t.messages.size() && t.messages[t.next]->sequence == g.number) logged.push_back(t.messages[t.next++]);
      const auto time = static_cast<std::uint64_t>(g.ctx.deadline_ns);
      if (output_)
        for (const auto& bytes : replayed) output_->write(t.output_channel, g.number, time, time, bytes);
      if (g.lost > 0) continue;
      const std::size_t n = std::max(replayed.size(), logged.size());
      for (std::size_t i = 0; i < n; ++i) {
        ++result_.writes;
        if (i < replayed.size() && i < logged.size() &&
            std::equal(replayed[i].begin(), replayed[i].end(), logged[i]->data.begin(), logged[i]->data.end()))
          continue;
        ++result_.differing;
        if (result_.mismatches.size() >= options_.keep) continue;
        ReplayMismatch& mm = result_.mismatches.emplace_back();
        mm.port = t.name;
        mm.cycle = g.ctx.cycle;
        mm.group = kGroupNames[g.kind];
        mm.deadline_ns = g.ctx.deadline_ns;
        mm.index = i;
        if (i < logged.size()) mm.logged = logged[i]->data;
        if (i < replayed.size()) mm.replayed = replayed[i];
      }
    }
    if (g.lost > 0) ++result_.unjudged;
  }

  std::string log_;
  const ReplayOptions& options_;
  mcap::Reader reader_;
  CycleLogInfo info_;
  std::uint16_t cycles_id_ = 0;
  std::vector<Tapped> tapped_;
  std::map<std::uint16_t, std::size_t> by_channel_;
  std::vector<mcap::Message> messages_;
  std::vector<Group> groups_;
  std::vector<std::unique_ptr<PortTap>> taps_;  // outlive the servant's ports' use of them
  std::unique_ptr<ComponentServant> servant_;
  std::unique_ptr<mcap::Writer> output_;
  ReplayResult result_;
};

}  // namespace

ReplayResult replay_cycle_log(std::unique_ptr<Component> component, const std::string& log, const ReplayOptions& options) {
  Replay replay(std::move(component), log, options);
  return replay.run();
}

}  // namespace rtm
