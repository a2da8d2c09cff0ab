// The errors the edges report: a configuration problem names the file, the key and the problem
// (exit 2); a file that cannot be written names the file and why (exit 1).
#pragma once

#include <cstdio>
#include <stdexcept>
#include <string>

namespace cdshear {

/// `text` as a terminal may show it: control characters other than line breaks and tabs (a NUL
/// would end the message, an escape sequence would act on the terminal) written as \xNN.
inline std::string printable(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char ch : text) {
    const auto byte = static_cast<unsigned char>(ch);
    if ((byte < 0x20 && ch != '\n' && ch != '\t') || byte == 0x7f) {
      char escaped[5];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", byte);
      out += escaped;
    } else {
      out += ch;
    }
  }
  return out;
}

class ConfigError : public std::runtime_error {
 public:
  /// `given_key`: the dotted key of the command-line override (`--set KEY=...`, `--velocity`)
  /// that `file` names, when the problem is blamed on one.
  ConfigError(const std::string& file, const std::string& key, const std::string& problem,
              const std::string& given_key = "")
      : std::runtime_error(
            printable(file + (key.empty() ? "" : ": key '" + key + "'") + ": " + problem)),
        file_(file),
        key_(key),
        problem_(problem),
        given_key_(given_key) {}
  const std::string& file() const { return file_; }
  const std::string& key() const { return key_; }
  /// The problem alone, to be told again under another file or key.
  const std::string& problem() const { return problem_; }
  /// The key of the override blamed (file() is then that override); empty when a file is.
  const std::string& given_key() const { return given_key_; }

 private:
  std::string file_;
  std::string key_;
  std::string problem_;
  std::string given_key_;
};

/// A file that could not be written (a full disk, a read-only or vanished folder): not bad
/// input, so `cdshear` exits 1; what was written before it stays (docs/reliability.md).
class WriteError : public std::runtime_error {
 public:
  WriteError(const std::string& file, const std::string& problem)
      : std::runtime_error(file + ": " + problem) {}
};

}  // namespace cdshear
