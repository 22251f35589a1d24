// Two doubles side by side in one SSE2 register, through the GCC and Clang
// vector extension: for loops whose lanes are independent and whose
// arithmetic must stay exactly the scalar one (the same operations in the
// same order), so that a value's bits do not depend on whether it was
// computed alone or in a pair.
#pragma once

#include <cstring>

namespace host_id {

using LanePair = double __attribute__((vector_size(2 * sizeof(double))));

inline LanePair load_pair(const double* at) {
  LanePair p;
  std::memcpy(&p, at, sizeof p);
  return p;
}

inline void store_pair(double* at, LanePair p) {
  std::memcpy(at, &p, sizeof p);
}

}  // namespace host_id
