// The fixture of cmake/CheckNoFloat.cmake's own test: a comment with an
// unbalanced bracket, [-2, 2), then a consteval body (allowed) and a double
// constant on line 9 (the one hit).
struct Q {
  static consteval Q from(long double v) {
    const long double scaled = v * 2.0L;
    return Q{static_cast<int>(scaled)};
  }
  static constexpr double kNotAllowed = 1.0;
  int raw;
};
