// Stop requests from outside: SIGINT, SIGTERM and SIGHUP set one flag that the run loop, the
// campaign schedulers and the analysis poll, so that a stopped process ends after the step (or
// the job) in progress and writes what it has. Child processes start with these signals' default
// actions instead, so that a stop reaches the programs they exec.
#pragma once

#include <sys/types.h>

#include <atomic>

namespace cdshear {

/// Set by the SIGINT/SIGTERM/SIGHUP handler; the loop stops after the current step.
extern std::atomic<bool> g_stop_requested;

/// Installs the handler that sets g_stop_requested for SIGINT, SIGTERM and SIGHUP (a closed
/// terminal or a batch system's hang-up).
void install_stop_handlers();

/// fork() with the stop signals (SIGINT, SIGTERM, SIGHUP) held across it. The child starts with
/// their default actions, then the caller's signal mask: a stop sent to the child before its exec
/// ends it, where the inherited handler would only set g_stop_requested in the child's copy of
/// this process's memory (which the exec discards) and the program it starts would run to its
/// end. The parent gets its mask back; a stop sent to it meanwhile is delivered then. Returns
/// fork()'s result; the child may call only async-signal-safe functions until it execs.
pid_t fork_with_default_stops();

}  // namespace cdshear
