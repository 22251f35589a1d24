#include "host_id/regression.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/signal.hpp"

namespace host_id {

Regression build_regression(const Model& model, const delta::Geometry& g, double gravity_m_s2,
                            const Samples& samples, const std::string& log_name, unsigned threads) {
  const std::size_t n = samples.size();
  const std::size_t p = model.size();
  // Row-major scratch so each sample writes 3 contiguous rows.
  std::vector<double> rows(3 * n * p);
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  // Below ~20k samples a second thread does not pay for its start-up.
  const std::size_t workers = std::min<std::size_t>(threads, std::max<std::size_t>(1, n / 20000));
  std::atomic<std::size_t> first_bad{n};
  std::vector<delta::KinematicsStatus> bad_status(workers, delta::KinematicsStatus::kOk);
  const auto work = [&](std::size_t w) {
    const std::size_t b = n * w / workers, e = n * (w + 1) / workers;
    for (std::size_t k = b; k < e; ++k) {
      const auto st = model.rows(g, gravity_m_s2, samples.states[k], &rows[3 * k * p]);
      if (st != delta::KinematicsStatus::kOk) {
        std::size_t expected = first_bad.load();
        while (k < expected && !first_bad.compare_exchange_weak(expected, k)) {
        }
        bad_status[w] = st;
        return;
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  if (const std::size_t k = first_bad.load(); k < n) {
    const auto& q = samples.states[k].q_rad;
    std::ostringstream s;
    s << log_name << ": sample at t = " << samples.t_s[k] << " s: joint angles (" << q[0] << ", "
      << q[1] << ", " << q[2] << ") rad have "
      << "no forward kinematics for this geometry (unreachable or singular pose); "
      << "check the geometry metadata and the angle convention";
    throw delta::InputError(s.str());
  }
  std::vector<double> tau(3 * n);
  for (std::size_t k = 0; k < n; ++k) {
    for (unsigned j = 0; j < 3; ++j) tau[3 * k + j] = samples.tau_Nm[k][j];
  }
  if (samples.parallel_filter) {
    // Column c of joint j within a segment is the strided series
    // rows[(3k + j) p + c]; tau likewise with stride 3.
    std::vector<double> series;
    for (const Segment& seg : samples.segments) {
      for (unsigned j = 0; j < 3; ++j) {
        for (std::size_t c = 0; c <= p; ++c) {
          series.clear();
          for (std::size_t k = seg.begin; k < seg.end; ++k) {
            series.push_back(c < p ? rows[(3 * k + j) * p + c] : tau[3 * k + j]);
          }
          const std::vector<double> f = filtfilt(samples.filter, series, samples.pad);
          for (std::size_t k = seg.begin; k < seg.end; ++k) {
            (c < p ? rows[(3 * k + j) * p + c] : tau[3 * k + j]) = f[k - seg.begin];
          }
        }
      }
    }
  }
  // Keep the samples away from the segment ends.
  std::vector<std::size_t> keep;
  keep.reserve(n);
  for (const Segment& seg : samples.segments) {
    for (std::size_t k = seg.begin + samples.trim; k + samples.trim < seg.end; ++k)
      keep.push_back(k);
  }
  Regression r;
  const auto m = static_cast<Eigen::Index>(3 * keep.size());
  r.psi.resize(m, static_cast<Eigen::Index>(p));
  r.tau.resize(m);
  r.t_s.reserve(keep.size());
  r.joint.reserve(3 * keep.size());
  r.speed_rad_s.reserve(3 * keep.size());
  r.sample.reserve(3 * keep.size());
  for (std::size_t i = 0; i < keep.size(); ++i) {
    const std::size_t k = keep[i];
    r.t_s.push_back(samples.t_s[k]);
    for (unsigned j = 0; j < 3; ++j) {
      const auto row = static_cast<Eigen::Index>(3 * i + j);
      r.joint.push_back(static_cast<unsigned char>(j));
      r.speed_rad_s.push_back(std::abs(samples.states[k].qd_rad_s[j]));
      r.sample.push_back(i);
      r.tau(row) = tau[3 * k + j];
      for (std::size_t c = 0; c < p; ++c)
        r.psi(row, static_cast<Eigen::Index>(c)) = rows[(3 * k + j) * p + c];
    }
  }
  return r;
}

std::array<std::size_t, 3> Regression::rows_per_joint() const {
  std::array<std::size_t, 3> n{};
  for (const unsigned char j : joint) ++n[j];
  return n;
}

Regression without_slow_rows(const Regression& r, double min_speed_rad_s) {
  std::vector<Eigen::Index> kept;
  kept.reserve(r.rows());
  for (std::size_t row = 0; row < r.rows(); ++row) {
    if (r.speed_rad_s[row] >= min_speed_rad_s) kept.push_back(static_cast<Eigen::Index>(row));
  }
  Regression out;
  out.t_s = r.t_s;
  out.psi = r.psi(kept, Eigen::all);
  out.tau = r.tau(kept);
  out.joint.reserve(kept.size());
  out.speed_rad_s.reserve(kept.size());
  out.sample.reserve(kept.size());
  for (const Eigen::Index row : kept) {
    const auto i = static_cast<std::size_t>(row);
    out.joint.push_back(r.joint[i]);
    out.speed_rad_s.push_back(r.speed_rad_s[i]);
    out.sample.push_back(r.sample[i]);
  }
  return out;
}

double direct_cost(const Regression& r, const Eigen::VectorXd& beta) {
  return (r.tau - r.psi * beta).squaredNorm() / static_cast<double>(r.tau.size());
}

QuadraticCost::QuadraticCost(const Regression& r, const Eigen::VectorXd& beta0)
    : beta0_(beta0), rows_(static_cast<double>(r.tau.size())) {
  const Eigen::VectorXd r0 = r.tau - r.psi * beta0;
  psi_t_psi_ = r.psi.transpose() * r.psi;
  psi_t_r0_ = r.psi.transpose() * r0;
  r0_t_r0_ = r0.squaredNorm();
}

double QuadraticCost::operator()(const Eigen::VectorXd& beta) const {
  const Eigen::VectorXd d = beta - beta0_;
  const double quad = d.dot(psi_t_psi_.selfadjointView<Eigen::Upper>() * d);
  return std::max(0.0, (r0_t_r0_ - 2.0 * d.dot(psi_t_r0_) + quad) / rows_);
}

std::array<double, 3> mean_square_per_joint(const Regression& r, const Eigen::VectorXd& e) {
  std::array<double, 3> sum{};
  for (std::size_t row = 0; row < r.rows(); ++row)
    sum[r.joint[row]] += std::pow(e(static_cast<Eigen::Index>(row)), 2);
  const std::array<std::size_t, 3> n = r.rows_per_joint();
  for (unsigned j = 0; j < 3; ++j) sum[j] = n[j] > 0 ? sum[j] / static_cast<double>(n[j]) : 0.0;
  return sum;
}

std::array<double, 3> rmse_per_joint(const Regression& r, const Eigen::VectorXd& beta) {
  std::array<double, 3> ms = mean_square_per_joint(r, r.tau - r.psi * beta);
  for (double& m : ms) m = std::sqrt(m);
  return ms;
}

}  // namespace host_id
