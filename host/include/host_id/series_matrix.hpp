// A regressor's storage: an Eigen matrix whose megabytes come from
// allocate_buffer (huge_pages.hpp), not from malloc.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cstddef>
#include <new>
#include <utility>

#include "host_id/huge_pages.hpp"

namespace host_id {

// A column-major matrix of doubles used as an Eigen matrix (it is an
// Eigen::Map over its own storage). Its storage comes from allocate_buffer,
// so that a regression's megabytes reuse the blocks a fit freed before it
// (the file's text, the joint states) instead of fresh pages, which the
// kernel must fault in and clear. As with Eigen::MatrixXd, resize to another
// size leaves the coefficients uninitialised.
class SeriesMatrix : public Eigen::Map<Eigen::MatrixXd> {
 public:
  using Base = Eigen::Map<Eigen::MatrixXd>;

  SeriesMatrix() : Base(nullptr, 0, 0) {}
  SeriesMatrix(Eigen::Index rows, Eigen::Index cols) : SeriesMatrix() { resize(rows, cols); }
  SeriesMatrix(const SeriesMatrix& other) : SeriesMatrix() { *this = other; }
  SeriesMatrix(SeriesMatrix&& other) noexcept : SeriesMatrix() { swap(other); }
  ~SeriesMatrix() { free_buffer(data(), bytes(size())); }

  SeriesMatrix& operator=(const SeriesMatrix& other) {
    if (this != &other) {
      resize(other.rows(), other.cols());
      std::copy_n(other.data(), other.size(), data());
    }
    return *this;
  }
  SeriesMatrix& operator=(SeriesMatrix&& other) noexcept {
    swap(other);
    return *this;
  }
  // The value of an Eigen expression (which may read this matrix).
  template <class Derived>
  SeriesMatrix& operator=(const Eigen::DenseBase<Derived>& value) {
    const Eigen::MatrixXd evaluated = value;
    resize(evaluated.rows(), evaluated.cols());
    Base::operator=(evaluated);
    return *this;
  }

  void resize(Eigen::Index rows, Eigen::Index cols) {
    if (rows * cols != size()) {
      SeriesMatrix fresh;
      fresh.take_storage(rows * cols);
      swap(fresh);
    }
    reseat(data(), rows, cols);
  }
  // New columns at the right (uninitialised); the first ones keep their values.
  void conservative_resize_columns(Eigen::Index cols) {
    SeriesMatrix grown;
    grown.take_storage(rows() * cols);
    std::copy_n(data(), rows() * std::min(cols, this->cols()), grown.data());
    grown.reseat(grown.data(), rows(), cols);
    swap(grown);
  }
  void swap(SeriesMatrix& other) noexcept {
    double* const p = data();
    const Eigen::Index r = rows(), c = cols();
    reseat(other.data(), other.rows(), other.cols());
    other.reseat(p, r, c);
  }

 private:
  static std::size_t bytes(Eigen::Index coefficients) {
    return static_cast<std::size_t>(coefficients) * sizeof(double);
  }
  // Storage for n coefficients, seated as one column; this has none.
  void take_storage(Eigen::Index n) {
    double* p = n > 0 ? static_cast<double*>(allocate_buffer(bytes(n))) : nullptr;
    reseat(p, n, n > 0 ? 1 : 0);
  }
  // Eigen's way to point a Map elsewhere: construct it anew in place.
  void reseat(double* p, Eigen::Index rows, Eigen::Index cols) noexcept {
    new (static_cast<Base*>(this)) Base(p, rows, cols);
  }
};

}  // namespace host_id
