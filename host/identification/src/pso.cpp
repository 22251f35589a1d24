#include "host_id/pso.hpp"

#include <algorithm>
#include <limits>
#include <vector>

#include "delta/splitmix.hpp"

namespace host_id {

namespace {

using Random = delta::SplitMix64;

constexpr double kChi = 0.72984378812835757;  // Clerc's constriction for phi = 4.1
constexpr double kC = 2.05;
constexpr double kMaxSpeed = 0.5;  // of the normalised box per iteration

// The swarm in normalised coordinates, particle by particle in flat arrays
// (particle i's coordinates at [i * dim, (i + 1) * dim)), so that a move is
// one loop over contiguous coordinates that the compiler vectorises.
struct Swarm {
  Swarm(std::size_t particles, std::size_t dimensions)
      : n(particles),
        dim(dimensions),
        x(n * dim),
        v(n * dim),
        pbest(n * dim),
        pbest_cost(n, std::numeric_limits<double>::infinity()),
        gbest(dim, 0.5),
        randoms(2 * dim) {}
  double* x_of(std::size_t i) { return x.data() + i * dim; }
  double* v_of(std::size_t i) { return v.data() + i * dim; }
  double* pbest_of(std::size_t i) { return pbest.data() + i * dim; }

  std::size_t n, dim;
  std::vector<double> x, v, pbest, pbest_cost, gbest;
  double gbest_cost{std::numeric_limits<double>::infinity()};
  std::vector<double> randoms;  // one move's r1 for every coordinate, then its r2
};

// The dim coordinates x (velocities v) moved towards the best p and the
// guide g with the draws r1, r2. A coordinate that leaves [0, 1] is put on
// the bound it crossed, its velocity reversed and halved.
void move_coordinates(double* x, double* v, const double* p, const double* g, const double* r1,
                      const double* r2, std::size_t dim) {
  for (std::size_t d = 0; d < dim; ++d) {
    const double vel =
        std::clamp(kChi * (v[d] + kC * r1[d] * (p[d] - x[d]) + kC * r2[d] * (g[d] - x[d])),
                   -kMaxSpeed, kMaxSpeed);
    const double pos = x[d] + vel;
    x[d] = std::clamp(pos, 0.0, 1.0);
    v[d] = x[d] == pos ? vel : -0.5 * vel;
  }
}

// Moves particle i towards its own best and its guide g. r1 and r2 of a
// coordinate are the two halves of one draw.
void move(Swarm& s, std::size_t i, const double* g, Random& rng) {
  double* r1 = s.randoms.data();
  double* r2 = r1 + s.dim;
  rng.fill_pairs(r1, r2, s.dim);
  move_coordinates(s.x_of(i), s.v_of(i), s.pbest_of(i), g, r1, r2, s.dim);
}

// Records particle i's cost c: its own best and the swarm's.
void record(Swarm& s, std::size_t i, double c) {
  if (!(c < s.pbest_cost[i])) return;
  s.pbest_cost[i] = c;
  std::copy_n(s.x_of(i), s.dim, s.pbest_of(i));
  if (c < s.gbest_cost) {
    s.gbest_cost = c;
    std::copy_n(s.x_of(i), s.dim, s.gbest.data());
  }
}

// The best of particle i's neighbours on the ring and itself.
std::size_t ring_guide(const Swarm& s, std::size_t i) {
  const std::size_t l = (i + s.n - 1) % s.n, r = (i + 1) % s.n;
  std::size_t b = i;
  if (s.pbest_cost[l] < s.pbest_cost[b]) b = l;
  if (s.pbest_cost[r] < s.pbest_cost[b]) b = r;
  return b;
}

}  // namespace

namespace {

class SwarmRun {
 public:
  SwarmRun(const NormalizedCost& cost, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
           const PsoOptions& options)
      : cost_(cost),
        lower_(lower),
        span_(upper - lower),
        options_(options),
        rng_(options.seed),
        swarm_(std::max<std::size_t>(options.particles, 2), static_cast<std::size_t>(lower.size())),
        guide_(swarm_.n) {}

  PsoResult run();

 private:
  // The cost at normalised point u.
  double evaluate(const double* u) {
    ++result_.evaluations;
    return cost_(u);
  }
  void scatter(bool keep_best);
  void iterate();
  bool stalled(std::size_t it);

  const NormalizedCost& cost_;
  const Eigen::VectorXd& lower_;
  const Eigen::VectorXd span_;
  const PsoOptions& options_;
  Random rng_;
  Swarm swarm_;
  std::vector<std::size_t> guide_;
  PsoResult result_;
  double checkpoint_cost_{0};
  std::size_t checkpoint_it_{0};
};

// Every particle at a random point with a random velocity; on a restart
// (keep_best) the first particle starts at the swarm's best point.
void SwarmRun::scatter(bool keep_best) {
  Swarm& s = swarm_;
  for (std::size_t i = 0; i < s.n; ++i) {
    double* x = s.x_of(i);
    double* v = s.v_of(i);
    for (std::size_t d = 0; d < s.dim; ++d) {
      x[d] = rng_.uniform();
      v[d] = (rng_.uniform() - x[d]) * 0.5;
    }
    if (keep_best && i == 0) std::copy_n(s.gbest.data(), s.dim, x);
    const double c = evaluate(x);
    std::copy_n(x, s.dim, s.pbest_of(i));
    s.pbest_cost[i] = c;
    if (c < s.gbest_cost) {
      s.gbest_cost = c;
      std::copy_n(x, s.dim, s.gbest.data());
    }
  }
}

// One iteration: each particle's guide from the bests at its start, then
// each particle moved and evaluated in turn (the swarm's best follows at once).
void SwarmRun::iterate() {
  Swarm& s = swarm_;
  const bool ring = options_.topology == PsoTopology::kRing;
  if (ring) {
    for (std::size_t i = 0; i < s.n; ++i) guide_[i] = ring_guide(s, i);
  }
  for (std::size_t i = 0; i < s.n; ++i) {
    move(s, i, ring ? s.pbest_of(guide_[i]) : s.gbest.data(), rng_);
    record(s, i, evaluate(s.x_of(i)));
  }
}

// Whether the search stops at iteration it: no relative gain above the
// tolerance for stall_iterations, and no restart left.
bool SwarmRun::stalled(std::size_t it) {
  if (swarm_.gbest_cost < checkpoint_cost_ * (1.0 - options_.stall_tolerance)) {
    checkpoint_cost_ = swarm_.gbest_cost;
    checkpoint_it_ = it;
    return false;
  }
  if (it - checkpoint_it_ < options_.stall_iterations) return false;
  if (result_.restarts_done == options_.restarts) return true;
  ++result_.restarts_done;
  scatter(true);
  checkpoint_it_ = it;
  return false;
}

PsoResult SwarmRun::run() {
  scatter(false);
  checkpoint_cost_ = swarm_.gbest_cost;
  std::size_t it = 0;
  result_.stop_reason = "iterations";
  for (; it < options_.iterations; ++it) {
    iterate();
    if (stalled(it)) {
      result_.stop_reason = "stall";
      ++it;
      break;
    }
    if (options_.progress && (it + 1) % options_.progress_every == 0) {
      options_.progress(it + 1, options_.iterations, swarm_.gbest_cost);
    }
  }
  if (options_.progress) options_.progress(it, options_.iterations, swarm_.gbest_cost);
  result_.iterations = it;
  const Eigen::Map<const Eigen::VectorXd> best(swarm_.gbest.data(), lower_.size());
  result_.best = lower_ + best.cwiseProduct(span_);
  result_.best_cost = swarm_.gbest_cost;
  for (std::size_t i = 0; i < swarm_.n; ++i) {
    const double* x = swarm_.x_of(i);
    if (std::any_of(x, x + swarm_.dim, [](double c) { return c <= 0.0 || c >= 1.0; })) {
      ++result_.particles_on_bound;
    }
  }
  return result_;
}

}  // namespace

PsoResult run_pso_normalized(const NormalizedCost& cost, const Eigen::VectorXd& lower,
                             const Eigen::VectorXd& upper, const PsoOptions& options) {
  return SwarmRun(cost, lower, upper, options).run();
}

PsoResult run_pso(const CostFunction& cost, const Eigen::VectorXd& lower,
                  const Eigen::VectorXd& upper, const PsoOptions& options) {
  // beta through one buffer: no allocation per evaluation.
  const Eigen::VectorXd span = upper - lower;
  Eigen::VectorXd beta(lower.size());
  const NormalizedCost at_beta = [&](const double* u) {
    const Eigen::Map<const Eigen::VectorXd> point(u, beta.size());
    beta.noalias() = lower + point.cwiseProduct(span);
    return cost(beta);
  };
  return run_pso_normalized(at_beta, lower, upper, options);
}

}  // namespace host_id
