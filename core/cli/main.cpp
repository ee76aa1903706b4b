// scancam: the command-line front end of the ScanCam core library.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>
#include <vector>

#include "command.h"
#include "scancam/error.h"
#include "scancam/output_file.h"
#include "scancam/progress.h"
#include "scancam/version.h"

namespace scancam::cli {

std::map<std::string, Command>& Registry() {
  static std::map<std::string, Command> registry;
  return registry;
}

bool Register(Command c) {
  c.options.push_back({"--help", "", "Show this help."});
  Registry()[c.name] = std::move(c);
  return true;
}

Args::Args(const std::vector<std::string>& argv, const std::vector<OptionSpec>& specs) {
  for (std::size_t i = 0; i < argv.size(); ++i) {
    const std::string& a = argv[i];
    if (a.size() > 2 && a.compare(0, 2, "--") == 0) {
      std::string key = a, value;
      bool has_inline = false;
      if (auto eq = a.find('='); eq != std::string::npos) {
        key = a.substr(0, eq);
        value = a.substr(eq + 1);
        has_inline = true;
      }
      const OptionSpec* spec = nullptr;
      for (const auto& s : specs)
        if (s.name == key) spec = &s;
      if (!spec) throw Error("unknown option " + key + " (see --help)");
      if (spec->value.empty()) {
        values_[key].push_back("1");
      } else {
        if (!has_inline) {
          if (i + 1 >= argv.size()) throw Error("option " + key + " needs a value " + spec->value);
          value = argv[++i];
        }
        if (!spec->repeatable && values_.count(key)) throw Error("option " + key + " given twice");
        values_[key].push_back(value);
      }
    } else {
      positional_.push_back(a);
    }
  }
}

std::string Args::get(const std::string& name, const std::string& fallback) const {
  auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second.back();
}
std::vector<std::string> Args::all(const std::string& name) const {
  auto it = values_.find(name);
  return it == values_.end() ? std::vector<std::string>{} : it->second;
}
std::string Args::required(const std::string& name) const {
  if (!has(name)) throw Error("missing required option " + name + " (see --help)");
  return get(name);
}
double Args::get_double(const std::string& name, double fallback) const {
  if (!has(name)) return fallback;
  const std::string v = get(name);
  try {
    std::size_t used = 0;
    double d = std::stod(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
    return d;
  } catch (const std::exception&) {
    throw Error("option " + name + ": '" + v + "' is not a number");
  }
}
std::vector<double> Args::get_numbers(const std::string& name, std::size_t count,
                                      const std::string& form) const {
  const std::string text = get(name);
  std::stringstream ss(text);
  std::string item;
  std::vector<double> v;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size() || !std::isfinite(v.back())) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      v.clear();
      break;
    }
  }
  if (v.size() != count || text.empty() || text.back() == ',')
    throw Error("option " + name + ": '" + text + "' is not " +
                (count == 2   ? std::string("two")
                 : count == 3 ? "three"
                              : std::to_string(count)) +
                " numbers " + form);
  return v;
}
Eigen::Vector3d Args::get_vector3(const std::string& name) const {
  const std::vector<double> v = get_numbers(name, 3, "X,Y,Z");
  return {v[0], v[1], v[2]};
}
int Args::get_int(const std::string& name, int fallback) const {
  if (!has(name)) return fallback;
  const std::string v = get(name);
  try {
    std::size_t used = 0;
    int d = std::stoi(v, &used);
    if (used != v.size()) throw std::invalid_argument(v);
    return d;
  } catch (const std::exception&) {
    throw Error("option " + name + ": '" + v + "' is not a whole number");
  }
}

std::string HelpText(const Command& c) {
  std::ostringstream o;
  o << "usage: " << c.usage << "\n\n" << c.description << "\n\noptions:\n";
  for (const auto& s : c.options) {
    std::string head = "  " + s.name + (s.value.empty() ? "" : " " + s.value);
    o << head;
    if (head.size() < 26) {
      o << std::string(26 - head.size(), ' ');
    } else {
      o << "\n" << std::string(26, ' ');
    }
    o << s.help << (s.repeatable ? " (repeatable)" : "") << "\n";
  }
  return o.str();
}

std::function<bool(double, const std::string&)> StderrProgress(bool quiet) {
  if (quiet) return {};
  auto last = std::make_shared<int>(-1);
  auto last_stage = std::make_shared<std::string>();
  return [last, last_stage](double f, const std::string& stage) {
    int pct = static_cast<int>(f * 100.0 + 0.5);
    if (pct != *last || stage != *last_stage) {
      if (pct / 10 != *last / 10 || stage != *last_stage || pct == 100) {
        std::fprintf(stderr, "[%s] %3d%%\n", stage.c_str(), pct);
      }
      *last = pct;
      *last_stage = stage;
    }
    return true;
  };
}

}  // namespace scancam::cli

namespace {
void PrintMainHelp() {
  std::cout << "scancam " << SCANCAM_VERSION_STRING
            << ": camera / 3D laser scanner calibration from natural scenes\n\n"
               "usage: scancam COMMAND [options]      (scancam COMMAND --help for details)\n\n"
               "commands:\n";
  for (const auto& [name, c] : scancam::cli::Registry()) {
    std::cout << "  " << name << std::string(name.size() < 12 ? 12 - name.size() : 1, ' ')
              << c.summary << "\n";
  }
  std::cout << "\nFrames: T_cam_scan maps scanner-frame points into the camera frame "
               "(X_cam = R X_scan + t),\nOpenCV camera frame (x right, y down, z forward), "
               "pixel (0,0) = centre of the top-left pixel.\n";
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h" || args[0] == "help") {
    PrintMainHelp();
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "scancam " << SCANCAM_VERSION_STRING << "\n";
    return 0;
  }
  auto& reg = scancam::cli::Registry();
  auto it = reg.find(args[0]);
  if (it == reg.end()) {
    std::cerr << "scancam: unknown command '" << scancam::PrintableText(args[0])
              << "' (see scancam --help)\n";
    return 2;
  }
  const auto& cmd = it->second;
  std::vector<std::string> rest(args.begin() + 1, args.end());
  for (const auto& a : rest) {
    if (a == "--help" || a == "-h") {
      std::cout << scancam::cli::HelpText(cmd);
      return 0;
    }
  }
  try {
    scancam::cli::Args parsed(rest, cmd.options);
    // Every output of the run is staged and only replaces its file when the run succeeds: a
    // run that fails leaves no output and the previous run's files as they were
    // (scancam/output_file.h).
    scancam::OutputBatch outputs;
    scancam::RemoveTemporariesOnSignals();  // Ctrl+C or kill: no .scancam-tmp-* left behind
    const int rc = cmd.run(parsed);
    if (rc == 0) outputs.Commit();
    return rc;
  } catch (const scancam::Cancelled& e) {
    std::cerr << "scancam " << cmd.name << ": " << scancam::PlainErrorMessage(e) << "\n";
    return 130;
  } catch (const std::exception& e) {
    // One plain line: no library framing, no raw bytes from a damaged file (PlainErrorMessage).
    std::cerr << "scancam " << cmd.name << ": error: " << scancam::PlainErrorMessage(e) << "\n";
    return 1;
  } catch (...) {
    std::cerr << "scancam " << cmd.name << ": error: unexpected failure (unknown exception)\n";
    return 1;
  }
}
