// Checkpoints: the complete dynamic state (world + contact memory for warm starts), written
// atomically as CBOR (nlohmann-json's binary format: doubles stored bit-exact), so that a run
// resumed from one continues exactly as if it had never stopped.
#pragma once

#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "contact.hpp"
#include "world.hpp"

namespace cdshear {

struct Checkpoint {
  World world;
  std::vector<Contact> contacts;  ///< keys and impulses (the rest is recomputed at detection)
  nlohmann::json observers;       ///< observers' running state (null when none was stored)
};

void write_checkpoint(const std::filesystem::path& path, const World& world,
                      const std::vector<Contact>& contacts,
                      const nlohmann::json& observers = nullptr);
/// Throws ConfigError naming the file when it is missing or not a cdshear checkpoint.
Checkpoint read_checkpoint(const std::filesystem::path& path);

}  // namespace cdshear
