#include "stop_signals.hpp"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <csignal>

namespace cdshear {

std::atomic<bool> g_stop_requested{false};

namespace {
extern "C" void on_stop_signal(int) {
  g_stop_requested.store(true);
}

constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};
}  // namespace

void install_stop_handlers() {
  for (const int signal : kStopSignals) std::signal(signal, on_stop_signal);
}

pid_t fork_with_default_stops() {
  sigset_t stops;
  sigset_t before;
  ::sigemptyset(&stops);
  for (const int signal : kStopSignals) ::sigaddset(&stops, signal);
  ::pthread_sigmask(SIG_BLOCK, &stops, &before);
  const pid_t pid = ::fork();
  if (pid == 0) {  // a stop already sent to the child ends it when the mask is restored
    for (const int signal : kStopSignals) ::signal(signal, SIG_DFL);
    ::sigprocmask(SIG_SETMASK, &before, nullptr);
  } else {
    ::pthread_sigmask(SIG_SETMASK, &before, nullptr);
  }
  return pid;
}

}  // namespace cdshear
