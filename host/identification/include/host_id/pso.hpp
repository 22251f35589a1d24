// Particle swarm optimisation with Clerc's constriction coefficients
// (chi = 0.7298, c1 = c2 = 2.05), global-best or ring topology, in
// coordinates normalised to the bounds. A coordinate that leaves the box is
// put back on the bound it crossed, and its velocity reversed and halved
// (docs/estimators.md: absorbing walls, velocity zeroed, let the swarm
// collapse onto a wall).
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>

namespace host_id {

enum class PsoTopology { kGlobal, kRing };

struct PsoOptions {
  std::size_t particles{40};
  std::size_t iterations{10000};  // as in the paper
  PsoTopology topology{PsoTopology::kGlobal};
  std::uint64_t seed{1};
  // Stall: no relative improvement of the best cost by more than
  // stall_tolerance within stall_iterations iterations.
  std::size_t stall_iterations{500};
  double stall_tolerance{1e-12};
  // On a stall, restart the swarm around the best point this many times
  // before stopping. None by default: the fit's cost is a convex quadratic
  // over a box, so a stall is at its one minimum, and no restart has yet
  // improved it (docs/estimators.md).
  std::size_t restarts{0};
  // Called every progress_every iterations (and at the end) when set.
  std::function<void(std::size_t iteration, std::size_t max_iterations, double best_cost)> progress;
  std::size_t progress_every{100};
};

struct PsoResult {
  Eigen::VectorXd best;
  double best_cost{0};
  std::size_t iterations{0};
  std::size_t evaluations{0};
  std::size_t restarts_done{0};
  std::string stop_reason;            // "iterations" or "stall"
  std::size_t particles_on_bound{0};  // particles with a coordinate on a bound at the end
};

using CostFunction = std::function<double(const Eigen::VectorXd&)>;

// Minimises cost over lower <= beta <= upper (every lower < upper, finite).
PsoResult run_pso(const CostFunction& cost, const Eigen::VectorXd& lower,
                  const Eigen::VectorXd& upper, const PsoOptions& options);

// A cost over the box's normalised coordinates: the n values from u on, each
// in [0, 1], stand for beta = lower + u (upper - lower). For a cost that is
// cheaper to evaluate there than at beta (QuadraticCost::over_box).
using NormalizedCost = std::function<double(const double* u)>;

// As run_pso, with the cost given over normalised coordinates: the same
// swarm, without mapping each point to beta. The result is in beta.
PsoResult run_pso_normalized(const NormalizedCost& cost, const Eigen::VectorXd& lower,
                             const Eigen::VectorXd& upper, const PsoOptions& options);

}  // namespace host_id
