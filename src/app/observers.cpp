#include "observers.hpp"

#include <fmt/format.h>

namespace cdshear {

SnapshotObserver::SnapshotObserver(std::filesystem::path dir, double dt, std::uint64_t every,
                                   std::uint64_t resumed_step)
    : dir_(std::move(dir)), dt_(dt) {
  // The folder is made at the first snapshot: a run that ends before one leaves none.
  for (std::uint64_t s = every; s <= resumed_step; s += every)
    if (std::filesystem::exists(dir_ / fmt::format("particles_{:010}.vtp", s)))
      add(s, static_cast<double>(s) * dt);
}

void SnapshotObserver::add(std::uint64_t step, double time) {
  particles_.push_back({time, fmt::format("particles_{:010}.vtp", step)});
  contacts_.push_back({time, fmt::format("contacts_{:010}.vtp", step)});
}

void SnapshotObserver::observe(const World& world, const ContactDynamics& dynamics,
                               const StepReport&) {
  // Time as step * dt (not the accumulated world.time) so that a resumed run lists the same.
  if (particles_.empty()) std::filesystem::create_directories(dir_);
  add(world.step, static_cast<double>(world.step) * dt_);
  write_particles_vtp(dir_ / particles_.back().file, world, dynamics.contacts());
  write_contacts_vtp(dir_ / contacts_.back().file, world, dynamics.contacts(), dt_);
  write_pvd(dir_ / "particles.pvd", particles_);
  write_pvd(dir_ / "contacts.pvd", contacts_);
}

}  // namespace cdshear
