#include "rt/thread.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/prctl.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

namespace rtm {

namespace {

void to_stderr(const std::string& message) { std::fprintf(stderr, "rtm: warning: %s\n", message.c_str()); }

std::atomic<WarningSink> warning_sink{&to_stderr};

}  // namespace

void set_warning_sink(WarningSink sink) { warning_sink.store(sink ? sink : &to_stderr); }

void warn(const std::string& message) { warning_sink.load()(message); }

void set_thread_name(std::string_view name) {
  const std::string cut(name.substr(0, 15));
  pthread_setname_np(pthread_self(), cut.c_str());
}

void apply_thread_settings(const ThreadSettings& settings) {
  prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);
  if (!settings.name.empty()) set_thread_name(settings.name);
  const std::string who = settings.name.empty() ? std::string("thread") : settings.name;
  if (settings.cpu >= 0) {
    cpu_set_t set;
    CPU_ZERO(&set);
    CPU_SET(settings.cpu, &set);
    if (int err = pthread_setaffinity_np(pthread_self(), sizeof(set), &set); err != 0)
      warn(who + ": cannot pin to CPU " + std::to_string(settings.cpu) + " (" + std::strerror(err) +
           "); running unpinned");
  }
  if (settings.fifo_priority > 0) {
    sched_param param{};
    param.sched_priority = settings.fifo_priority;
    if (int err = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); err != 0)
      warn(who + ": SCHED_FIFO priority " + std::to_string(settings.fifo_priority) + " refused (" +
           std::strerror(err) + "); running SCHED_OTHER" +
           (err == EPERM ? " (needs CAP_SYS_NICE or an rtprio limit)" : ""));
  }
  if (settings.lock_memory && mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
    warn(who + ": mlockall refused (" + std::strerror(errno) + "); page faults may delay cycles");
}

}  // namespace rtm
