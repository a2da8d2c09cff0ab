// libFuzzer target over every reader of user files: case files, scene files, packings,
// checkpoints, run.h5 files, `--set` overrides and campaign files. The first byte picks the reader,
// the rest is the input. The property: a reader either accepts its input or throws ConfigError (a
// clear error naming the file); any other exception, a crash, a sanitizer report or a hang is a
// bug. Build and run: docs/reliability.md ("Fuzzing").
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "campaign_file.hpp"
#include "case_file.hpp"
#include "checkpoint.hpp"
#include "config_error.hpp"
#include "packing_file.hpp"
#include "run_data_file.hpp"
#include "scene_file.hpp"
#include "toml_reader.hpp"

namespace {

const std::filesystem::path& scratch_file() {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("cdshear_fuzz_" + std::to_string(::getpid()));
  return path;
}

void write_input(const std::string& bytes) {
  std::ofstream(scratch_file(), std::ios::binary | std::ios::trunc) << bytes;
}

constexpr int kReaders = 7;

void read_with(std::uint8_t reader, const std::string& bytes) {
  using namespace cdshear;
  switch (reader % kReaders) {
    case 0: {  // case file
      write_input(bytes);
      CaseSource src;
      src.file = scratch_file().string();
      load_case(src);
      break;
    }
    case 1:  // scene file (read and validated, not built: building is the simulation's job)
      write_input(bytes);
      load_scene_file(scratch_file().string(), {});
      break;
    case 2:  // packing
      write_input(bytes);
      read_packing(scratch_file());
      break;
    case 3:  // checkpoint
      write_input(bytes);
      read_checkpoint(scratch_file());
      break;
    case 4: {  // --set overrides on the built-in case, one per line of the input
      CaseSource src;
      std::string line;
      for (const char ch : bytes) {
        if (ch == '\n') {
          src.overrides.push_back(line);
          line.clear();
        } else {
          line += ch;
        }
      }
      src.overrides.push_back(line);
      load_case(src);
      break;
    }
    case 5:  // run.h5
      write_input(bytes);
      read_run_data(scratch_file());
      break;
    case 6:  // campaign file (every run resolved by the case loader)
      write_input(bytes);
      read_campaign(scratch_file().string());
      break;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    read_with(data[0], bytes);
  } catch (const cdshear::ConfigError&) {
    // The expected way to refuse an input.
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reader %d threw a %s instead of a ConfigError: %s\n", data[0] % kReaders,
                 typeid(e).name(), e.what());
    std::abort();
  }
  return 0;
}
