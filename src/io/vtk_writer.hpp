// Snapshots for ParaView: particles and contact force lines as VTK XML PolyData (.vtp), collected
// in .pvd time series. Written by hand (ASCII XML, about a hundred lines): the VTK library would
// add a very large dependency for two simple file formats.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "contact.hpp"
#include "world.hpp"

namespace cdshear {

/// Disks as vertices with point data radius, velocity, omega, contact_count (force-carrying).
void write_particles_vtp(const std::filesystem::path& path, const World& world,
                         const std::vector<Contact>& contacts);
/// Force-carrying contacts as lines between centres (to the periodic image of b, or to the
/// contact point for a wall) with cell data normal_force and tangential_force (impulse / dt).
void write_contacts_vtp(const std::filesystem::path& path, const World& world,
                        const std::vector<Contact>& contacts, double dt);

struct PvdEntry {
  double time = 0.0;
  std::string file;  ///< relative to the .pvd
};
void write_pvd(const std::filesystem::path& path, const std::vector<PvdEntry>& entries);

}  // namespace cdshear
