#include "preprocess_rows.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <sstream>

#include "delta/input_error.hpp"
#include "host_id/parallel.hpp"
#include "host_id/signal.hpp"

namespace host_id::preprocessing {

void RowLayout::order_rows(const std::vector<Segment>& segments, const States& s,
                           double slow_below_rad_s, const std::string& log_name) {
  if (!(slow_below_rad_s > 0.0)) return;
  if (3 * kept_ > std::numeric_limits<std::uint32_t>::max()) {
    throw delta::InputError(log_name + ": " + std::to_string(kept_) +
                            " samples are more than a fit can order (at most " +
                            std::to_string(std::numeric_limits<std::uint32_t>::max() / 3) + ")");
  }
  rows_.resize(3 * kept_);
  // Marks first (1: fast), then each mark becomes its row.
  std::size_t i = 0;
  for (const Segment& seg : segments) {
    for (std::size_t k = seg.begin + trim_; k + trim_ < seg.end; ++k, ++i) {
      for (unsigned j = 0; j < 3; ++j) {
        const bool fast = std::abs(s.states[k].qd_rad_s[j]) >= slow_below_rad_s;
        rows_[3 * i + j] = fast ? 1u : 0u;
        fast_ += fast ? 1 : 0;
      }
    }
  }
  std::uint32_t next_fast = 0, next_slow = static_cast<std::uint32_t>(fast_);
  for (std::uint32_t& r : rows_) r = r != 0 ? next_fast++ : next_slow++;
}

namespace {

// The regression's rows and tau in their places: psi column-major (the
// regression's own storage), the side rows row-major, tau of both alike.
struct RowStore {
  Eigen::MatrixXd& psi;
  Eigen::VectorXd& tau;
  std::vector<double> side_rows;  // 3 p per trimmed sample
  std::vector<double> side_tau;   // 3 per trimmed sample
  std::size_t p;
  double& at(bool on_side, std::size_t row, std::size_t c) {
    return on_side ? side_rows[row * p + c]
                   : psi(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(c));
  }
  double& tau_at(bool on_side, std::size_t row) {
    return on_side ? side_tau[row] : tau(static_cast<Eigen::Index>(row));
  }
};

// A kept sample's labels: its time, and its rows' joints, speeds and sample.
void label_kept(const States& s, std::size_t k, std::size_t i, const RowLayout& layout,
                Regression& r) {
  r.t_s[i] = s.t_s[k];
  for (unsigned j = 0; j < 3; ++j) {
    const std::size_t row = layout.row(i, j);
    r.joint[row] = static_cast<unsigned char>(j);
    r.velocity_rad_s[row] = s.states[k].qd_rad_s[j];
    r.sample[row] = i;
  }
}

// The unfiltered rows' moments are summed per chunk of this many samples,
// and the chunks' sums added in order: the same sums on any number of
// threads (a worker takes whole chunks).
constexpr std::size_t kMomentChunk = 1024;

// A worker's rows of the samples it builds together (at most a chunk):
// row-major, 3 p values per sample, the torque of each row, and the
// regressor row each kept row goes to. Built row by row in this small
// buffer and then copied out a column at a time: written straight into the
// column-major regressor, a sample's rows are stores to p columns far
// apart, which wait on memory.
struct ChunkRows {
  explicit ChunkRows(std::size_t p)
      : rows(3 * kMomentChunk * p), tau(3 * kMomentChunk), to_row(3 * kMomentChunk) {}
  std::vector<double> rows;
  std::vector<double> tau;
  std::vector<std::size_t> to_row;
};

// Where the rows of the samples go.
struct RowFill {
  const Model& model;
  const DeltaLog& log;
  const States& s;
  const RowLayout& layout;
  RowStore& store;
  Regression& r;

  // Samples [b, e) of segment si (no more than a chunk): their rows and
  // torques into their places, the columns not zero marked in nz (3 p, per
  // joint); the kept samples' labels, and their unfiltered rows into
  // `moments`. The first sample whose pose has no forward kinematics, or e.
  std::size_t samples(std::size_t si, std::size_t b, std::size_t e, ChunkRows& chunk,
                      unsigned char* nz, MeasuredMoments& moments) const {
    const std::size_t p = model.size();
    const Segment& seg = s.segments[si];
    const std::size_t len = seg.end - seg.begin;
    // The kept samples of a segment are one run between its trimmed ends.
    std::size_t kept_b = e, kept_e = e;
    for (std::size_t k = b; k < e; ++k) {
      double* rows = &chunk.rows[3 * (k - b) * p];
      if (model.rows(log.geometry, log.gravity_m_s2, s.states[k], s.tau_Nm[k], rows) !=
          delta::KinematicsStatus::kOk) {
        return k;
      }
      for (unsigned j = 0; j < 3; ++j) chunk.tau[3 * (k - b) + j] = s.tau_Nm[k][j];
      bool side = false;
      const std::size_t i = layout.place(si, k - seg.begin, len, side);
      if (side) {
        put_aside(rows, &chunk.tau[3 * (k - b)], i, nz);
        continue;
      }
      kept_b = std::min(kept_b, k);
      kept_e = k + 1;
      label_kept(s, k, i, layout, r);
      for (unsigned j = 0; j < 3; ++j) chunk.to_row[3 * (k - b) + j] = layout.row(i, j);
    }
    if (kept_b < kept_e) put_kept(chunk, kept_b - b, kept_e - b, nz, moments);
    return e;
  }

  // A trimmed sample's three rows (row-major) and torques into the side
  // buffers at its side index i.
  void put_aside(const double* rows, const double* tau, std::size_t i, unsigned char* nz) const {
    const std::size_t p = model.size();
    for (unsigned j = 0; j < 3; ++j) {
      for (std::size_t c = 0; c < p; ++c) {
        const double v = rows[j * p + c];
        store.at(true, 3 * i + j, c) = v;
        nz[j * p + c] |= static_cast<unsigned char>(v != 0.0);
      }
      store.tau_at(true, 3 * i + j) = tau[j];
    }
  }

  // The kept samples [first, last) of the chunk: each column copied to the
  // regressor, tau alike, and each joint's rows into the moments.
  void put_kept(const ChunkRows& chunk, std::size_t first, std::size_t last, unsigned char* nz,
                MeasuredMoments& moments) const {
    const std::size_t p = model.size();
    for (std::size_t c = 0; c < p; ++c) {
      double* column = &store.psi(0, static_cast<Eigen::Index>(c));
      for (unsigned j = 0; j < 3; ++j) {
        bool any = false;
        for (std::size_t t = 3 * first + j; t < 3 * last; t += 3) {
          const double v = chunk.rows[t * p + c];
          column[chunk.to_row[t]] = v;
          any = any || v != 0.0;
        }
        nz[j * p + c] |= static_cast<unsigned char>(any);
      }
    }
    for (std::size_t t = 3 * first; t < 3 * last; ++t) {
      store.tau(static_cast<Eigen::Index>(chunk.to_row[t])) = chunk.tau[t];
    }
    const auto n = static_cast<Eigen::Index>(last - first);
    const auto pi = static_cast<Eigen::Index>(p);
    for (unsigned j = 0; j < 3; ++j) {
      // Joint j's rows as the columns of a p x n matrix, and its torques.
      const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> rows(
          &chunk.rows[(3 * first + j) * p], pi, n, Eigen::OuterStride<>(3 * pi));
      const Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<3>> tau(
          &chunk.tau[3 * first + j], n);
      moments.add(j, rows, tau);
    }
  }
};

// Each sample's regressor rows (forward kinematics, Jacobian, lambda) into
// their places, on `threads` threads; and tau alike. The kept samples'
// labels go into r (sized for them), their unfiltered rows into r.measured;
// nonzero[j p + c] says whether column c of joint j is anywhere other than
// zero.
void fill_rows(const Model& model, const DeltaLog& log, const States& s, const RowLayout& layout,
               RowStore& store, Regression& r, std::vector<unsigned char>& nonzero,
               unsigned threads) {
  const std::size_t n = s.size();
  const std::size_t p = model.size();
  const std::size_t workers = workers_for(n, threads, kSamplesPerThread);
  const std::size_t chunks = (n + kMomentChunk - 1) / kMomentChunk;
  const RowFill fill{model, log, s, layout, store, r};
  std::atomic<std::size_t> first_bad{n};
  std::vector<MeasuredMoments> chunk_moments(chunks);
  std::vector<std::vector<unsigned char>> nonzero_of(workers, std::vector<unsigned char>(3 * p));
  std::vector<ChunkRows> rows_of(workers, ChunkRows(p));
  // Chunk c on worker w, its moments summed alone, a segment's part at a
  // time. The workers take the next chunk left, so that a thread the
  // machine slows down does less; a chunk after a bad sample is skipped.
  const auto work = [&](std::size_t w, std::size_t c) {
    if (first_bad.load() < c * kMomentChunk) return;
    MeasuredMoments& moments = chunk_moments[c];
    moments.reset(p);
    for (std::size_t si = 0; si < s.segments.size(); ++si) {
      const std::size_t b = std::max(s.segments[si].begin, c * kMomentChunk);
      const std::size_t e = std::min(s.segments[si].end, (c + 1) * kMomentChunk);
      if (b >= e) continue;
      const std::size_t bad = fill.samples(si, b, e, rows_of[w], nonzero_of[w].data(), moments);
      if (bad == e) continue;
      std::size_t expected = first_bad.load();
      while (bad < expected && !first_bad.compare_exchange_weak(expected, bad)) {
      }
      return;
    }
  };
  run_tasks(chunks, workers, work);
  nonzero.assign(3 * p, 0);
  for (const auto& nz : nonzero_of) {
    for (std::size_t k = 0; k < nz.size(); ++k) nonzero[k] |= nz[k];
  }
  if (const std::size_t k = first_bad.load(); k < n) {
    const auto& q = s.states[k].q_rad;
    std::ostringstream m;
    m << log.name << ": sample at t = " << s.t_s[k] << " s: joint angles (" << q[0] << ", " << q[1]
      << ", " << q[2] << ") rad have "
      << "no forward kinematics for this geometry (unreachable or singular pose); "
      << "check the geometry metadata and the angle convention";
    throw delta::InputError(m.str());
  }
  r.measured.reset(p);  // every chunk was summed
  for (const MeasuredMoments& m : chunk_moments) r.measured.merge(m);
}

// One series of the regression: a column (p: tau) in one joint's rows.
struct JointSeries {
  std::size_t column;
  unsigned joint;
};

// One sample's series as the filter's lanes: lane l is series lanes[l] in
// the sample's row of its joint.
struct SampleLanes {
  std::array<double*, 3> row;  // each joint's row: its first column
  std::array<double*, 3> tau;
  std::ptrdiff_t column_step;  // from one column to the next
  const JointSeries* lanes;
  std::size_t p;
  double& operator[](std::size_t l) const {
    const JointSeries& x = lanes[l];
    return x.column == p ? *tau[x.joint]
                         : row[x.joint][static_cast<std::ptrdiff_t>(x.column) * column_step];
  }
};

// A task filters about this many series side by side: enough that their
// recurrences overlap, few enough that the tasks are many for the threads
// to share.
constexpr std::size_t kLanesPerTask = 6;

// The series of one segment in tasks: each column's joints (those it is
// not zero in, from fill_rows) in one task, so that a task reads whole
// cache lines of the column-major regressor, and tau's alike.
std::vector<std::vector<JointSeries>> series_tasks(const std::vector<unsigned char>& nonzero,
                                                   std::size_t p) {
  std::vector<std::vector<JointSeries>> tasks(1);
  for (std::size_t c = 0; c <= p; ++c) {
    std::vector<JointSeries> column;
    for (unsigned j = 0; j < 3; ++j) {
      if (c == p || nonzero[j * p + c]) column.push_back({c, j});
    }
    if (tasks.back().size() + column.size() > kLanesPerTask) tasks.emplace_back();
    tasks.back().insert(tasks.back().end(), column.begin(), column.end());
  }
  return tasks;
}

// Filters every column of Psi and tau per segment and joint with the same
// zero-phase filter as q ("parallel filtering": filtering is linear, so
// filt(tau) = filt(Psi) beta holds exactly), through the trimmed ends too.
// The series are independent: a task is a few of one segment's series
// (series_tasks), filtered side by side, and the tasks are shared out over
// the threads.
void filter_columns(const FilterDesign& d, const std::vector<Segment>& segments,
                    const RowLayout& layout, RowStore& store,
                    const std::vector<unsigned char>& nonzero, std::size_t samples,
                    unsigned threads) {
  const std::vector<std::vector<JointSeries>> tasks = series_tasks(nonzero, store.p);
  const auto ld = static_cast<std::ptrdiff_t>(store.psi.outerStride());
  const auto run = [&](std::size_t si, const std::vector<JointSeries>& lanes) {
    const std::size_t len = segments[si].end - segments[si].begin;
    filtfilt_lanes(d.filter, len, lanes.size(), d.pad, [&](std::size_t q) {
      bool side = false;
      const std::size_t i = layout.place(si, q, len, side);
      SampleLanes at{{}, {}, side ? 1 : ld, lanes.data(), store.p};
      for (unsigned j = 0; j < 3; ++j) {
        const std::size_t row = side ? 3 * i + j : layout.row(i, j);
        at.row[j] =
            side ? &store.side_rows[row * store.p] : &store.psi(static_cast<Eigen::Index>(row), 0);
        at.tau[j] = side ? &store.side_tau[row] : &store.tau(static_cast<Eigen::Index>(row));
      }
      return at;
    });
  };
  const std::size_t workers = workers_for(samples, threads, kSamplesPerThread);
  run_tasks(segments.size() * tasks.size(), workers,
            [&](std::size_t, std::size_t k) { run(k / tasks.size(), tasks[k % tasks.size()]); });
}

}  // namespace

RowLayout layout_of(const States& s, const FilterDesign& d, double slow_below_rad_s,
                    const std::string& log_name) {
  RowLayout layout(s.segments, d.trim);
  layout.order_rows(s.segments, s, slow_below_rad_s, log_name);
  return layout;
}

Regression regression_of(const Model& model, const DeltaLog& log, States& s, const FilterDesign& d,
                         const RowLayout& layout, unsigned threads, bool free_states) {
  const std::size_t p = model.size();
  Regression r;
  r.psi.resize(static_cast<Eigen::Index>(3 * layout.kept()), static_cast<Eigen::Index>(p));
  r.tau.resize(static_cast<Eigen::Index>(3 * layout.kept()));
  RowStore store{r.psi, r.tau, std::vector<double>(3 * layout.trimmed() * p),
                 std::vector<double>(3 * layout.trimmed()), p};
  r.t_s.resize(layout.kept());
  r.joint.resize(3 * layout.kept());
  r.velocity_rad_s.resize(3 * layout.kept());
  r.sample.resize(3 * layout.kept());
  std::vector<unsigned char> nonzero;
  fill_rows(model, log, s, layout, store, r, nonzero, threads);
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t c = 0; c < p; ++c) {
      if (nonzero[j * p + c]) r.joint_columns[j].push_back(static_cast<Eigen::Index>(c));
    }
  }
  r.joint_columns_of = static_cast<Eigen::Index>(p);
  const std::vector<Segment> segments = s.segments;
  const std::size_t samples = s.size();
  if (free_states) s = States{};
  if (!d.logged_derivatives) filter_columns(d, segments, layout, store, nonzero, samples, threads);
  return r;
}

}  // namespace host_id::preprocessing
