// SPDX-License-Identifier: Apache-2.0
// The force-servo demo's analysis: the recorded port streams in, a per-phase summary, a
// merged CSV and a gnuplot script out. No CORBA: the demo records with `rtm watch --csv`
// and this library reads those files (and `rtm --json ls -l` for the loop timing).
//
// Sign convention. The wrist sensor reads the reaction force, so the force the hand applies is
// the reading negated: measured_N = -sensor. The controller drives ref + sensor to zero
// (paper Fig. 6), so the force error is error_N = ref - measured_N = ref + sensor, and a
// settled press has measured_N == ref.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace rtm::demo {

// ============================ errors ==================================

// An unreadable or malformed input: the message names the file and, where known, the line.
class ReportError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// ============================ recorded streams ========================

// One port's recording: a TimedFloat6 per row, in arrival order.
struct Series {
  std::vector<std::int64_t> time_ns;          // the datum's stamp (CLOCK_REALTIME)
  std::vector<std::array<double, 6>> values;  // v0..v5
};

// Reads `rtm watch --csv` output: header "time_ns" and six columns (named after the port's
// elements, e.g. fx..tz, else v0..v5), then one row per datum. A row with fewer than 6 values
// or a non-number throws ReportError naming file and line. A file
// cut short by a killed writer (last line without newline and incomplete) loses that row only.
Series read_watch_csv(const std::filesystem::path& path);
Series parse_watch_csv(const std::string& text, const std::string& source_name);

// ============================ aligned samples =========================

// One instant of the loop, on the sensor's time base.
struct Sample {
  double time_s = 0;                       // since the first sensor sample
  std::array<double, 3> reference_N{};     // the joystick's force (the operator's push)
  std::array<double, 3> measured_N{};      // -sensor force: what the hand applies
  std::array<double, 6> velocity{};        // controller command: m/s (0..2), rad/s (3..5)
};

// For each sensor sample, the latest reference and command stamped at or before it (the ones
// the loop had then); sensor samples before the first reference are dropped, and a command
// not yet produced counts as zero. Throws ReportError when a stream is empty or the streams do
// not overlap in time (e.g. stamped on different clocks).
std::vector<Sample> align(const Series& reference, const Series& sensor, const Series& command);

// ============================ phases ==================================

struct PhaseOptions {
  double reference_tolerance_N = 0.05;  // a phase: the reference stays this close to its start
  double min_duration_s = 0.5;          // shorter constant stretches are transitions
  double settle_band_N = 0.5;           // settled: |error| stays within this to the phase end
  double min_settled_s = 0.25;          // ... for at least this long (else a crossing near the
                                        // end of an oscillating phase would count)
  double steady_window_s = 1.0;         // steady state: the phase's last second
  double contact_threshold_N = 1.0;     // |mean measured| above this: the hand touches
};

// A stretch of constant reference: [begin, end) indices into the samples.
struct Phase {
  std::size_t begin = 0;
  std::size_t end = 0;
};

// The maximal stretches where the reference stays within reference_tolerance_N of the
// stretch's first value for at least min_duration_s. Ramps between them belong to none.
std::vector<Phase> detect_phases(const std::vector<Sample>& samples, const PhaseOptions& options);

struct PhaseSummary {
  double start_s = 0, end_s = 0;
  std::array<double, 3> reference_N{};       // at the phase start
  std::array<double, 3> mean_measured_N{};   // over the steady window
  std::array<double, 3> mean_velocity_m_s{};  // over the steady window
  // The error is ref - measured along the reference's direction (the whole vector when the
  // reference is below contact_threshold_N): pressing "at 10 N" is about the normal force.
  double steady_error_N = 0;                 // |mean error| over the steady window
  double error_peak_to_peak_N = 0;           // max - min of |error| over the steady window
  double lateral_N = 0;                      // |mean measured across the reference| (friction)
  std::optional<double> settling_time_s;     // from the phase start; none: not settled
                                             // for min_settled_s before the phase end
  bool contact = false;                      // |mean measured| > contact_threshold_N
  bool free_space() const { return !contact; }
};

// Throws std::invalid_argument for an empty or out-of-range phase.
PhaseSummary summarize(const std::vector<Sample>& samples, const Phase& phase,
                       const PhaseOptions& options);

// ============================ demo figures ============================
//
// The figures the demo promises for a press on the table (defaults: the project's limits).
// The force "along the reference" at a sample is measured_N . reference_N / |reference_N|, and
// the error there is |reference_N| minus that; the reference presses while |reference_N| >
// PhaseOptions::contact_threshold_N. The settling band is PhaseOptions::settle_band_N.
//
// 1. Touch-down overshoot. A touch-down is a sample where the reference presses and the force
//    along it rises to PhaseOptions::contact_threshold_N or above, having been below it (or,
//    while the reference did not press, the force's norm below it) since the previous
//    touch-down's window; a recording that starts in contact has none until it lifts. Its
//    transient window runs from the touch-down up to a limit: the end of the constant-reference
//    phase the touch-down falls in or, for a touch-down during a ramp, of the phase the ramp
//    leads into (the next reference change); earlier where the reference stops pressing or
//    the recording ends. The force has settled at the first sample after the last one in the
//    window whose error is outside the band, provided the stretch from there to the limit
//    lasts PhaseOptions::min_settled_s (as PhaseSummary::settling_time_s: settled means it
//    stays settled); the window then ends there. A bounce (the force dropping below the
//    threshold and rising again) inside the window belongs to the same touch-down; the next
//    touch-down is looked for after the window. Overshoot = the peak force along the
//    reference in the window / |reference| at the peak's sample - 1 (0.2 = 20 %).
// 2. Settling after touch-down: from the touch-down to the settled sample above (none when the
//    force does not settle before the limit). Checked for every touch-down.
// 3. Settling after a step in contact: a phase whose reference presses, in contact
//    (PhaseSummary::contact, pressing along the reference) and already touching at its first
//    sample (force along the reference at or above the contact threshold), e.g. 10 -> 20 N:
//    its PhaseSummary::settling_time_s, from the end of the reference's ramp (the phase start).
// 4. Release: from the end of the last press phase (a contact phase whose mean force along its
//    reference exceeds the contact threshold) to the end of the recording, the number of
//    times |force along that phase's reference| crosses release_level_N in either direction.
//    One (a single lift) is the clean case; the recording must also end lifted.
// 5. Watchdog events: the statistic "watchdog_events" a component (the actuator) publishes,
//    less those a host stall explains when the demo's witness classified them.
// A figure that cannot be measured (no touch-down, no step in contact, no press, no
// watchdog statistic) is reported as such and counts as missed.

struct FigureLimits {
  double max_overshoot = 0.20;             // touch-down peak / reference - 1
  double max_touch_down_settling_s = 0.3;  // touch-down to settled within the band
  double max_step_settling_s = 0.3;        // end of a reference ramp in contact to settled
  double release_level_N = 0.5;            // |force| level whose crossings count at release
  int max_release_transitions = 2;         // crossings of that level after the last press
  double max_watchdog_events = 0;
  // Of the watchdog events, those a host stall explains (the demo's wake-up witness saw one
  // overlapping the event): the limit then applies to the others. -1: not classified.
  double explained_watchdog_events = -1;
};

struct TouchDown {
  double time_s = 0;                         // the force along the reference reached the threshold
  std::array<double, 3> reference_N{};       // at the touch-down
  double peak_N = 0;                         // peak force along the reference in the window
  double peak_time_s = 0;
  double peak_reference_N = 0;               // |reference| at the peak's sample
  double overshoot = 0;                      // peak_N / peak_reference_N - 1
  double window_end_s = 0;                   // end of the transient window
  std::optional<double> settling_time_s;     // from time_s; none: not settled in the window
};

struct StepInContact {
  std::size_t phase = 0;                     // index into the phases given to compute_figures
  double start_s = 0;                        // the phase start: the end of the reference's ramp
  double from_N = 0;                         // the previous phase's reference along this one's
  double to_N = 0;                           // |reference| of the phase
  std::optional<double> settling_time_s;     // the phase's, from start_s
};

struct Release {
  std::size_t phase = 0;                     // the last press phase
  double start_s = 0, end_s = 0;             // its end, the recording's end
  std::array<double, 3> axis{};              // unit vector of that phase's reference
  int transitions = 0;                       // crossings of release_level_N
  bool lifted = false;                       // |force along axis| < release_level_N at the end
};

struct DemoFigures {
  std::vector<TouchDown> touch_downs;
  std::vector<StepInContact> steps;
  std::optional<Release> release;            // none: no press phase
};

// The figures of a recording, given its phases (detect_phases, in time order). Throws
// ReportError for no samples or a non-finite force, std::invalid_argument for phases out of
// range or out of order and for limits or options that make no sense (non-positive band,
// contact threshold or release level, negative durations).
DemoFigures compute_figures(const std::vector<Sample>& samples, const std::vector<Phase>& phases,
                            const PhaseOptions& options, const FigureLimits& limits = {});

// ============================ loop timing =============================

// One of the statistics a component publishes (`rtm cat`), e.g. the actuator's
// "watchdog_events" or "latency_p99" [us].
struct NamedStatistic {
  std::string name;
  double value = 0;
  std::string unit;
};

struct ComponentTiming {
  std::string name;
  std::string kind;
  std::string state;
  std::int64_t period_ns = 0;
  std::uint64_t cycles = 0;
  std::uint64_t overruns = 0;  // cycles more than one period late
  std::int64_t lateness_p99_ns = 0;
  std::int64_t lateness_max_ns = 0;
  std::string last_error;  // why it is in error ("" when not)
  std::vector<NamedStatistic> statistics;  // as the component reports them
  // Its timing contract and how it kept it (docs/timing.md); none when it is not watched.
  struct Contract {
    std::int64_t deadline_ns = 0, budget_ns = 0;
    std::uint64_t missed_deadline = 0, over_budget = 0;
    std::int64_t response_p99_ns = 0, response_max_ns = 0, cycle_p99_ns = 0, cycle_max_ns = 0;
  };
  std::optional<Contract> contract;
};

// Parses `rtm --json ls -l` output: timing and each component's statistics. Components without
// timing (on-arrival) get cycles 0.
// Throws ReportError for text that is not that JSON.
std::vector<ComponentTiming> parse_timing_json(const std::string& text, const std::string& source_name);

// ============================ output ==================================

// A statistic and the component that reported it.
struct FoundStatistic {
  std::string component;
  NamedStatistic statistic;
};
// The first component in timing that reports statistic `name` (none: no component does).
std::optional<FoundStatistic> find_statistic(const std::vector<ComponentTiming>& timing, std::string_view name);

struct Report {
  std::vector<PhaseSummary> phases;
  DemoFigures figures;                  // compute_figures on the same phases
  std::vector<ComponentTiming> timing;  // with the components' statistics: watchdog events,
                                        // sample-to-drive latency, command-loss recoveries
  std::size_t samples = 0;
  double duration_s = 0;
  // false for a motion script's run (script_report.h): its reference is partly a velocity
  // asked for through the controller's gain, not an operator's push, so figures 1-4 and the
  // phases' steady-state errors do not apply; the script's own figures do.
  bool operator_figures = true;
};

// One figure of the demo against its limit, as the summary prints it.
struct FigureVerdict {
  std::string figure;  // e.g. "touch-down overshoot"
  std::string value;   // what was measured, or why it could not be
  std::string limit;   // e.g. "<= 20 %"
  bool ok = false;
};

// Figures 1-5 above against limits, in that order (one line per touch-down and per step);
// figure 5 alone when !report.operator_figures.
std::vector<FigureVerdict> evaluate_figures(const Report& report, const PhaseOptions& options,
                                            const FigureLimits& limits = {});

// Everything --check refuses, one line each: the figures that are not ok, a contact phase
// whose steady-state error exceeds the settling band, a component with overruns.
std::vector<std::string> missed_figures(const Report& report, const PhaseOptions& options,
                                        const FigureLimits& limits = {});

// The summary as the demo prints it (plain text, one table per part; the demo figures last,
// each with its limit and "ok" or "MISSED").
std::string format_report(const Report& report, const PhaseOptions& options,
                          const FigureLimits& limits = {});

// Merged CSV: time_s, ref_x..z [N], measured_x..z [N], error [N], v_x..z [m/s], w_x..z [rad/s].
void write_samples_csv(const std::filesystem::path& path, const std::vector<Sample>& samples);

// A gnuplot script drawing `csv` into `png`: reference vs measured force per axis, and the
// commanded translational velocity (mm/s), sharing the time axis. Phase starts are marked.
std::string gnuplot_script(const std::filesystem::path& csv, const std::filesystem::path& png,
                           const std::vector<PhaseSummary>& phases);

// ============================ live display ============================

// One row of a recording: time_ns and the six values.
using Row = std::array<double, 7>;

// The newest complete row of a recording's text: the last line that ends in '\n' and holds
// seven numbers (a recorder's buffered write can end mid-line); nullopt when none. The text's
// first line counts as whole.
std::optional<Row> last_complete_row(std::string_view tail);
// The same read from the end of the file (its last 4 KiB, one pread); nullopt when the file
// is missing or holds no complete row yet.
std::optional<Row> last_complete_row_of(const std::filesystem::path& path);

// The demo's live line at t s: the phase the reference says (hands off below 0.5 N, a press
// when it points down more than sideways, else a free-space push), the reference and the
// measured force [N] and the commanded velocity [mm/s], x y z. A missing row reads as zeros.
std::string live_line(int t_s, const Row& reference, const Row& sensor, const Row& command);

}  // namespace rtm::demo
