// Observers: the engine's time series (CSV, `scene`), checkpoints, VTK snapshots, and the feed of
// the shear measurement layer.
// They read the simulation state and never change it.
#pragma once

#include <filesystem>
#include <functional>
#include <vector>

#include "checkpoint.hpp"
#include "interval_stats.hpp"
#include "outputs.hpp"
#include "run_loop.hpp"
#include "shear_measurement.hpp"
#include "vtk_writer.hpp"

namespace cdshear {

/// A CSV row every `every` steps; schedule it every step: it gathers the solver statistics of
/// each interval (capped steps, largest sweeps, residual, overlap) so that none goes unseen.
class TimeSeriesObserver : public Observer {
 public:
  TimeSeriesObserver(const std::filesystem::path& path, const World& world, std::uint64_t every)
      : writer_(path, world), every_(every) {}
  void observe(const World& world, const ContactDynamics&, const StepReport& r) override {
    interval_.add(r);
    if (world.step % every_ != 0) return;
    writer_.write(world, r, interval_);
    interval_ = IntervalStats{};
  }

 private:
  TimeSeriesWriter writer_;
  std::uint64_t every_;
  IntervalStats interval_;
};

/// Writes the checkpoint; `before` runs first (writing the files the checkpoint's state refers
/// to, such as run.h5) and `observer_state` gives the observers' running state to store in it.
class CheckpointObserver : public Observer {
 public:
  struct Hooks {
    std::function<void(const World&, const ContactDynamics&)> before;
    std::function<nlohmann::json()> observer_state;
    nlohmann::json case_identity;  ///< stored in every checkpoint
  };
  explicit CheckpointObserver(std::filesystem::path path, Hooks hooks = {})
      : path_(std::move(path)), hooks_(std::move(hooks)) {}
  void observe(const World& world, const ContactDynamics& dynamics, const StepReport& r) override {
    if (r.blown_up) return;  // never replace the last good checkpoint with a broken state
    if (hooks_.before) hooks_.before(world, dynamics);
    write_checkpoint(path_, world, dynamics.contacts(),
                     hooks_.observer_state ? hooks_.observer_state() : nlohmann::json(),
                     hooks_.case_identity);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  Hooks hooks_;
};

/// Feeds the measurement layer after every step (schedule it every step).
class MeasurementObserver : public Observer {
 public:
  explicit MeasurementObserver(ShearMeasurement& measurement) : measurement_(measurement) {}
  void observe(const World& world, const ContactDynamics& dynamics, const StepReport& r) override {
    if (r.blown_up) return;  // a broken state (NaN, huge overlaps) is not measured
    measurement_.after_step(world, dynamics.contacts(), r);
  }

 private:
  ShearMeasurement& measurement_;
};

/// particles_<step>.vtp and contacts_<step>.vtp in `dir`, listed in particles.pvd and
/// contacts.pvd. On resume, every snapshot on disk up to the resumed step is listed again,
/// whatever interval wrote it, at the time the earlier particles.pvd gave it (step x dt where
/// it gave none).
class SnapshotObserver : public Observer {
 public:
  SnapshotObserver(std::filesystem::path dir, double dt, std::uint64_t resumed_step = 0);
  void observe(const World& world, const ContactDynamics& dynamics, const StepReport&) override;
  /// True once a snapshot is listed (written by this run or kept from before a resume).
  bool any() const { return !particles_.empty(); }

 private:
  void add(std::uint64_t step, double time);
  std::filesystem::path dir_;
  double dt_;
  std::vector<PvdEntry> particles_, contacts_;
};

}  // namespace cdshear
