// Small fixed-size vector and 3x3 matrix, templated on the scalar type so that
// the same kinematics can serve double (host, emulator) and, later, other
// scalar types. No heap, no exceptions.
#pragma once

#include <array>
#include <cstddef>

namespace delta {

template <class T>
struct Vec3 {
  T x{}, y{}, z{};

  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(T s) const { return {x * s, y * s, z * s}; }
  constexpr T dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  constexpr Vec3 cross(const Vec3& o) const {
    return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
  }
  constexpr T squared_norm() const { return dot(*this); }
  constexpr T operator[](std::size_t i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

template <class T>
constexpr Vec3<T> operator*(T s, const Vec3<T>& v) {
  return v * s;
}

// Row-major 3x3 matrix.
template <class T>
struct Mat3 {
  std::array<Vec3<T>, 3> row{};

  constexpr Vec3<T> operator*(const Vec3<T>& v) const {
    return {row[0].dot(v), row[1].dot(v), row[2].dot(v)};
  }
  constexpr T operator()(std::size_t r, std::size_t c) const { return row[r][c]; }
  constexpr T determinant() const { return row[0].dot(row[1].cross(row[2])); }
  constexpr Mat3 transposed() const {
    return {{Vec3<T>{row[0].x, row[1].x, row[2].x}, Vec3<T>{row[0].y, row[1].y, row[2].y},
             Vec3<T>{row[0].z, row[1].z, row[2].z}}};
  }
  // Adjugate: inverse() = adjugate() / determinant().
  constexpr Mat3 adjugate() const {
    // Columns of the inverse are the cross products of the rows.
    const Mat3 cof{{row[1].cross(row[2]), row[2].cross(row[0]), row[0].cross(row[1])}};
    return cof.transposed();
  }
};

}  // namespace delta
