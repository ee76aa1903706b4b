// scancam CLI: subcommand registry and a small argument parser.
//
// Each subcommand lives in its own file and registers itself with
// SCANCAM_COMMAND; main() dispatches. Subcommands only parse arguments into the
// core's options structs and call the core.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace scancam::cli {

/// One documented option of a subcommand.
struct OptionSpec {
  std::string name;   ///< "--out"
  std::string value;  ///< value placeholder ("DIR"); empty for a flag
  std::string help;   ///< one or more sentences
  bool repeatable = false;
};

/// Parsed arguments: positionals and --key value pairs (repeatable keys keep all values).
class Args {
 public:
  /// Parses argv against the specs; throws scancam::Error on an unknown option or a
  /// missing value.
  Args(const std::vector<std::string>& argv, const std::vector<OptionSpec>& specs);
  bool has(const std::string& name) const { return values_.count(name) > 0; }
  std::string get(const std::string& name, const std::string& fallback = "") const;
  std::vector<std::string> all(const std::string& name) const;
  /// Required option: throws scancam::Error "missing --name".
  std::string required(const std::string& name) const;
  double get_double(const std::string& name, double fallback) const;
  int get_int(const std::string& name, int fallback) const;
  /// Three finite numbers "X,Y,Z"; throws scancam::Error naming the option otherwise.
  Eigen::Vector3d get_vector3(const std::string& name) const;
  /// `count` finite numbers separated by commas; throws scancam::Error "option NAME: 'TEXT'
  /// is not COUNT numbers FORM" otherwise (FORM e.g. "A0,A1").
  std::vector<double> get_numbers(const std::string& name, std::size_t count,
                                  const std::string& form) const;
  const std::vector<std::string>& positional() const { return positional_; }

 private:
  std::map<std::string, std::vector<std::string>> values_;
  std::vector<std::string> positional_;
};

struct Command {
  std::string name;
  std::string summary;  ///< one line for `scancam --help`
  std::string usage;    ///< "scancam ba SCAN --out DIR [options]"
  std::string description;
  std::vector<OptionSpec> options;
  std::function<int(const Args&)> run;
};

/// Registry of subcommands (ordered by name).
std::map<std::string, Command>& Registry();
bool Register(Command c);

/// Full help text of one subcommand.
std::string HelpText(const Command& c);

/// Progress on stderr ("[stage] 42%"), rate-limited; silent when quiet.
std::function<bool(double, const std::string&)> StderrProgress(bool quiet);

}  // namespace scancam::cli

#define SCANCAM_CLI_CONCAT2(a, b) a##b
#define SCANCAM_CLI_CONCAT(a, b) SCANCAM_CLI_CONCAT2(a, b)
/// Registers a Command built by the expression `make` at static-initialisation time.
#define SCANCAM_COMMAND(make)                                               \
  static const bool SCANCAM_CLI_CONCAT(scancam_cmd_registered_, __LINE__) = \
      ::scancam::cli::Register(make)
