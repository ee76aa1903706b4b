#include "params_options.h"

#include "scancam/error.h"

namespace scancam::cli {

OptionSpec ParamsOptionSpec(const std::string& keys, const std::string& writer) {
  return {"--params", "FILE.json",
          "Options from a JSON parameter file (" + writer + "; keys in " + keys +
              "). Flags given here override it."};
}

void ThrowFirstOptionProblem(const std::vector<io::OptionProblem>& problems,
                             const std::vector<std::pair<std::string, std::string>>& flags) {
  if (problems.empty()) return;
  const io::OptionProblem& p = problems[0];
  std::string flag = "--params key '" + p.key + "'";
  for (const auto& f : flags)
    if (p.key == f.first) flag = f.second;
  throw Error("option " + flag + ": " + p.message);
}

}  // namespace scancam::cli
