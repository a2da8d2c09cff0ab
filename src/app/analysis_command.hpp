// `cdshear analyze RUN_DIR`, `cdshear plot RUN_DIR` and `cdshear report CAMPAIGN_DIR`: the per-run
// analysis, figures and campaign reports live in the Python package python/cdshear_analysis (numpy,
// scipy, matplotlib, h5py from Debian); these commands run it with /usr/bin/python3 so that
// `cdshear` stays the one entry point.
#pragma once

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace cdshear {

/// Where the analysis package (the folder holding `cdshear_analysis/`) is taken from, in this
/// order: CDSHEAR_ANALYSIS_DIR; the install beside this executable (`cmake --install`: the
/// package's folder relative to the executable's, CDSHEAR_INSTALLED_PYTHON_DIR); the `python`
/// folder of the source tree it was built from.
struct AnalysisPackage {
  std::filesystem::path dir;  ///< the folder to put on PYTHONPATH
  std::string source;         ///< "CDSHEAR_ANALYSIS_DIR", "install" or "source tree"
  bool found = false;         ///< dir/cdshear_analysis/__main__.py exists
};
AnalysisPackage find_analysis_package();

/// Runs `python3 -m cdshear_analysis <verb> <dir> <extra...>` (a run folder, or a campaign folder
/// for `report`); returns its exit status.
int run_analysis(const std::string& verb, const std::filesystem::path& run_dir,
                 const std::vector<std::string>& extra);

void register_analysis_commands(CLI::App& app);

}  // namespace cdshear
