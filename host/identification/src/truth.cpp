#include "host_id/truth.hpp"

namespace host_id {

std::map<std::string, double> parameter_truth(const ModelOptions& options,
                                              const delta::RobotDescription& robot) {
  std::map<std::string, double> t;
  if (options.name == "paper14") return t;
  const auto model = make_model(options);
  const delta::HighFidelityParameters physical =
      options.name == "delta" ? delta::high_fidelity_truth(robot)
                              : delta::to_high_fidelity(delta::lumped_truth(robot));
  const std::vector<double> v = model->parameter_vector(physical);
  for (std::size_t c = 0; c < v.size(); ++c) t[model->parameters()[c].name] = v[c];
  return t;
}

}  // namespace host_id
