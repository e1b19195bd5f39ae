#pragma once
// Counting the members of an aggregate (the technique of Boost.PFR: the most initialisers T{...}
// accepts), against the fields its visit_fields lists (core/schema.hpp, docs/options.md): a member
// added to an options struct and not to its list fails the tests that compare the two.
#include <cstddef>
#include <utility>

#include "autoscan/core/schema.hpp"

namespace autoscan::test {

struct AnyField {
  template <class T>
  operator T() const;  // declared only: used in unevaluated contexts
};

template <class T, std::size_t... I>
constexpr bool brace_initializable(std::index_sequence<I...>) {
  return requires { T{(static_cast<void>(I), AnyField{})...}; };
}

/// Number of members of the aggregate T.
template <class T, std::size_t N = 0>
constexpr std::size_t member_count() {
  if constexpr (brace_initializable<T>(std::make_index_sequence<N + 1>{}))
    return member_count<T, N + 1>();
  else
    return N;
}

struct FieldCounter {
  std::size_t n = 0;
  template <class U>
  void operator()(const char*, U&, schema::Range = {}) {
    ++n;
  }
};

/// Number of fields T's visit_fields lists.
template <class T>
std::size_t listed_fields() {
  T o;
  FieldCounter c;
  o.visit_fields(c);
  return c.n;
}

}  // namespace autoscan::test
