#include "host_id/pso.hpp"

#include <algorithm>
#include <limits>
#include <vector>

namespace host_id {

namespace {

// SplitMix64: a small, fully specified generator, so that a seed gives the
// same swarm on every platform and standard library.
class Random {
 public:
  explicit Random(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

 private:
  std::uint64_t state_;
};

constexpr double kChi = 0.72984378812835757;  // Clerc's constriction for phi = 4.1
constexpr double kC = 2.05;
constexpr double kMaxSpeed = 0.5;  // of the normalised box per iteration

}  // namespace

PsoResult run_pso(const CostFunction& cost, const Eigen::VectorXd& lower,
                  const Eigen::VectorXd& upper, const PsoOptions& options) {
  const Eigen::Index dim = lower.size();
  const std::size_t n = std::max<std::size_t>(options.particles, 2);
  const Eigen::VectorXd span = upper - lower;
  Random rng(options.seed);
  PsoResult result;

  std::vector<Eigen::VectorXd> x(n, Eigen::VectorXd(dim)), v(n, Eigen::VectorXd(dim));
  std::vector<Eigen::VectorXd> pbest(n);
  std::vector<double> pbest_cost(n, std::numeric_limits<double>::infinity());
  Eigen::VectorXd gbest_u = Eigen::VectorXd::Constant(dim, 0.5);
  double gbest_cost = std::numeric_limits<double>::infinity();

  Eigen::VectorXd beta(dim);  // the point evaluated, in one buffer: no allocation per call
  const auto evaluate = [&](const Eigen::VectorXd& u) {
    ++result.evaluations;
    beta.noalias() = lower + u.cwiseProduct(span);
    return cost(beta);
  };
  const auto scatter = [&](bool keep_best) {
    for (std::size_t i = 0; i < n; ++i) {
      for (Eigen::Index d = 0; d < dim; ++d) {
        x[i](d) = rng.uniform();
        v[i](d) = (rng.uniform() - x[i](d)) * 0.5;
      }
      if (keep_best && i == 0) x[i] = gbest_u;
      const double c = evaluate(x[i]);
      pbest[i] = x[i];
      pbest_cost[i] = c;
      if (c < gbest_cost) {
        gbest_cost = c;
        gbest_u = x[i];
      }
    }
  };
  scatter(false);

  double checkpoint_cost = gbest_cost;
  std::size_t checkpoint_it = 0;
  std::size_t it = 0;
  result.stop_reason = "iterations";
  std::vector<std::size_t> guide(n);
  for (; it < options.iterations; ++it) {
    // Each particle's guide: the best of its neighbourhood.
    for (std::size_t i = 0; i < n; ++i) {
      if (options.topology == PsoTopology::kGlobal) {
        guide[i] = n;  // sentinel: global best
      } else {
        const std::size_t l = (i + n - 1) % n, r = (i + 1) % n;
        std::size_t b = i;
        if (pbest_cost[l] < pbest_cost[b]) b = l;
        if (pbest_cost[r] < pbest_cost[b]) b = r;
        guide[i] = b;
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::VectorXd& g = guide[i] == n ? gbest_u : pbest[guide[i]];
      for (Eigen::Index d = 0; d < dim; ++d) {
        double vel = kChi * (v[i](d) + kC * rng.uniform() * (pbest[i](d) - x[i](d)) +
                             kC * rng.uniform() * (g(d) - x[i](d)));
        vel = std::clamp(vel, -kMaxSpeed, kMaxSpeed);
        double pos = x[i](d) + vel;
        if (pos < 0.0) {
          pos = 0.0;
          vel = -0.5 * vel;
        } else if (pos > 1.0) {
          pos = 1.0;
          vel = -0.5 * vel;
        }
        x[i](d) = pos;
        v[i](d) = vel;
      }
      const double c = evaluate(x[i]);
      if (c < pbest_cost[i]) {
        pbest_cost[i] = c;
        pbest[i] = x[i];
        if (c < gbest_cost) {
          gbest_cost = c;
          gbest_u = x[i];
        }
      }
    }
    if (gbest_cost < checkpoint_cost * (1.0 - options.stall_tolerance)) {
      checkpoint_cost = gbest_cost;
      checkpoint_it = it;
    } else if (it - checkpoint_it >= options.stall_iterations) {
      if (result.restarts_done < options.restarts) {
        ++result.restarts_done;
        scatter(true);
        checkpoint_it = it;
      } else {
        result.stop_reason = "stall";
        ++it;
        break;
      }
    }
    if (options.progress && (it + 1) % options.progress_every == 0) {
      options.progress(it + 1, options.iterations, gbest_cost);
    }
  }
  if (options.progress) options.progress(it, options.iterations, gbest_cost);
  result.iterations = it;
  result.best = lower + gbest_u.cwiseProduct(span);
  result.best_cost = gbest_cost;
  for (std::size_t i = 0; i < n; ++i) {
    if ((x[i].array() <= 0.0).any() || (x[i].array() >= 1.0).any()) ++result.particles_on_bound;
  }
  return result;
}

}  // namespace host_id
