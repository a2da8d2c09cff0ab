// Observers that write files on a schedule: the global time series, checkpoints, VTK snapshots.
// They read the simulation state and never change it.
#pragma once

#include <filesystem>
#include <vector>

#include "checkpoint.hpp"
#include "outputs.hpp"
#include "run_loop.hpp"
#include "vtk_writer.hpp"

namespace cdshear {

class TimeSeriesObserver : public Observer {
 public:
  TimeSeriesObserver(const std::filesystem::path& path, const World& world, bool append = false)
      : writer_(path, world, append) {}
  void observe(const World& world, const ContactDynamics&, const StepReport& r) override {
    writer_.write(world, r);
  }

 private:
  TimeSeriesWriter writer_;
};

class CheckpointObserver : public Observer {
 public:
  explicit CheckpointObserver(std::filesystem::path path) : path_(std::move(path)) {}
  void observe(const World& world, const ContactDynamics& dynamics, const StepReport& r) override {
    if (r.blown_up) return;  // never replace the last good checkpoint with a broken state
    write_checkpoint(path_, world, dynamics.contacts());
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// particles_<step>.vtp and contacts_<step>.vtp in `dir`, listed in particles.pvd and
/// contacts.pvd. On resume, snapshots up to the resumed step that exist on disk are kept.
class SnapshotObserver : public Observer {
 public:
  SnapshotObserver(std::filesystem::path dir, double dt, std::uint64_t every,
                   std::uint64_t resumed_step = 0);
  void observe(const World& world, const ContactDynamics& dynamics, const StepReport&) override;

 private:
  void add(std::uint64_t step, double time);
  std::filesystem::path dir_;
  double dt_;
  std::vector<PvdEntry> particles_, contacts_;
};

}  // namespace cdshear
