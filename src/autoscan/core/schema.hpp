#pragma once
// One options schema (docs/options.md): every options struct lists its fields once, next to the
// struct, in a member template
//
//   template <class V> void visit_fields(V& v) {
//     v("depth", depth, schema::closed(2, 12));   // JSON key, the field, its admissible range
//     v("screening", screening, schema::at_least(0));
//     v("weight_scalar", weight_scalar);          // no range: any value of the type
//     v("iso", iso);                              // a nested options struct: its own fields
//   }
//
// and everything else walks that list: JSON out (write), JSON in (read: present keys override,
// unknown keys are an InputError naming the key and the file, ranges checked as they enter) and the
// range checks of validate() (check). A field that is not in the list is neither saved, read nor
// checked, and tests/core's round trip of every struct through JSON catches it.
//
// Field types: bool, integers, double (always finite), std::string, std::filesystem::path,
// std::vector<int>, std::vector<double>, nlohmann::json (an object), Eigen::Isometry3d (16 numbers,
// row-major), enums with an ADL-visible `enum_names(E)` (below), and nested structs with
// visit_fields. A struct may also have `void validate(const std::string& what) const` for rules
// between fields; check() calls it for nested structs (after their ranges).
//
// Only nlohmann/json_fwd.hpp here: the JSON work is done by the non-template functions of
// schema.cpp, so public headers do not pull in the full json.hpp.
#include <Eigen/Geometry>
#include <concepts>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

namespace autoscan::schema {

/// The admissible values of a numeric field: [lo, hi] with either end open, optionally also 0 (an
/// "automatic" value outside the range). Doubles are always required to be finite.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;
  bool hi_open = false;
  bool zero_too = false;
  /// The same range, and 0 too (0 = automatic).
  constexpr Range or_zero() const {
    Range r = *this;
    r.zero_too = true;
    return r;
  }
  constexpr bool contains(double x) const {
    if (zero_too && x == 0.0) return true;
    return (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
  }
};
constexpr Range any() { return {}; }
/// [lo, hi]
constexpr Range closed(double lo, double hi) { return {lo, hi, false, false, false}; }
/// [lo, ∞)
constexpr Range at_least(double lo) { return {lo, std::numeric_limits<double>::infinity(), false, false, false}; }
/// (lo, ∞)
constexpr Range above(double lo) { return {lo, std::numeric_limits<double>::infinity(), true, false, false}; }
/// (lo, hi)
constexpr Range open(double lo, double hi) { return {lo, hi, true, true, false}; }
/// [lo, hi)
constexpr Range closed_open(double lo, double hi) { return {lo, hi, false, true, false}; }
/// (lo, hi]
constexpr Range open_closed(double lo, double hi) { return {lo, hi, true, false, false}; }

/// One value of an enum and its JSON name. A enum E used in an options struct has, in its own
/// namespace, `constexpr std::span<const schema::EnumName<E>> enum_names(E)`.
template <class E>
struct EnumName {
  E value;
  const char* name;
};

/// A struct that lists its fields.
struct Probe {
  template <class T>
  void operator()(const char*, T&, Range = {}) {}
};
template <class T>
concept Described = requires(T& t, Probe& p) {
  t.visit_fields(p);
};

template <class T>
concept HasEnumNames = std::is_enum_v<T> && requires(T e) {
  {enum_names(e)};
};

/// Has rules between its fields, checked after the ranges.
template <class T>
concept HasValidate = requires(const T& t, const std::string& what) {
  t.validate(what);
};

namespace detail {
// ---- JSON, implemented in schema.cpp (so that only json_fwd.hpp is needed here) ------------------
void make_object(nlohmann::json& j);
nlohmann::json& put_object(nlohmann::json& obj, const char* key);  ///< obj[key] = {}, returns it
void put(nlohmann::json& obj, const char* key, bool x);
void put(nlohmann::json& obj, const char* key, long long x);
void put(nlohmann::json& obj, const char* key, unsigned long long x);
void put(nlohmann::json& obj, const char* key, double x);
void put(nlohmann::json& obj, const char* key, const std::string& x);
void put(nlohmann::json& obj, const char* key, const std::vector<int>& x);
void put(nlohmann::json& obj, const char* key, const std::vector<double>& x);
void put(nlohmann::json& obj, const char* key, const nlohmann::json& x);
void put(nlohmann::json& obj, const char* key, const Eigen::Isometry3d& x);

/// `where` names the value in messages: "<file>: <path>".
void require_object(const nlohmann::json& j, const std::string& where);
/// The member `key` of the object `obj`, or nullptr.
const nlohmann::json* get(const nlohmann::json& obj, const char* key);
/// InputError "<what>: [<path>: ]unknown option '<key>' (known: ...)" for a key of `obj` not in
/// `known` (`path` is "" or ends with '.').
void refuse_unknown(const nlohmann::json& obj, const std::vector<const char*>& known, const std::string& what,
                    const std::string& path);
bool read_bool(const nlohmann::json& v, const std::string& where);
long long read_signed(const nlohmann::json& v, long long lo, long long hi, const std::string& where);
unsigned long long read_unsigned(const nlohmann::json& v, unsigned long long hi, const std::string& where);
double read_double(const nlohmann::json& v, const std::string& where);
std::string read_string(const nlohmann::json& v, const std::string& where);
std::vector<int> read_int_list(const nlohmann::json& v, const std::string& where);
std::vector<double> read_double_list(const nlohmann::json& v, const std::string& where);
void read_object(const nlohmann::json& v, nlohmann::json& out, const std::string& where);
Eigen::Isometry3d read_matrix(const nlohmann::json& v, const std::string& where);
/// InputError "<what>: unknown value '<name>' for <path> (expected one of: ...)".
[[noreturn]] void unknown_enum(const std::string& name, const std::vector<const char*>& known,
                               const std::string& where);

// ---- ranges -------------------------------------------------------------------------------------
/// InputError "<what>: <path> must be <range> (got <x>)" when x is outside r (or not finite).
void check_range(double x, const Range& r, const std::string& what, const std::string& path);
void check_finite(const std::vector<double>& x, const Range& r, const std::string& what, const std::string& path);
void check_list(const std::vector<int>& x, const Range& r, const std::string& what, const std::string& path);
void check_matrix(const Eigen::Isometry3d& x, const std::string& what, const std::string& path);
inline std::string join(const std::string& what, const std::string& path) { return what + ": " + path; }

template <class T>
inline constexpr bool is_leaf_v =
    std::is_same_v<T, bool> || std::is_integral_v<T> || std::is_floating_point_v<T> || HasEnumNames<T> ||
    std::is_same_v<T, std::string> || std::is_same_v<T, std::filesystem::path> || std::is_same_v<T, std::vector<int>> ||
    std::is_same_v<T, std::vector<double>> || std::is_same_v<T, nlohmann::json> || std::is_same_v<T, Eigen::Isometry3d>;

// ---- the three walkers --------------------------------------------------------------------------
struct Writer {
  nlohmann::json& j;
  template <class T>
  void operator()(const char* key, T& x, Range = {}) {
    if constexpr (Described<T>) {
      Writer w{put_object(j, key)};
      x.visit_fields(w);
    } else if constexpr (HasEnumNames<T>) {
      for (const auto& e : enum_names(x))
        if (e.value == x) return put(j, key, std::string(e.name));
      put(j, key, std::string("?"));
    } else if constexpr (std::is_same_v<T, bool>) {
      put(j, key, x);
    } else if constexpr (std::is_integral_v<T> && std::is_signed_v<T>) {
      put(j, key, static_cast<long long>(x));
    } else if constexpr (std::is_integral_v<T>) {
      put(j, key, static_cast<unsigned long long>(x));
    } else if constexpr (std::is_floating_point_v<T>) {
      put(j, key, static_cast<double>(x));
    } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
      put(j, key, x.string());
    } else {
      static_assert(is_leaf_v<T>, "schema: unsupported field type");
      put(j, key, x);
    }
  }
};

struct Reader {
  const nlohmann::json& j;
  const std::string& what;  ///< the file (or option) the JSON came from
  std::string path;         ///< "" or "poisson." for nested objects
  std::vector<const char*> known;

  template <class T>
  void operator()(const char* key, T& x, Range r = {}) {
    known.push_back(key);
    const nlohmann::json* v = get(j, key);
    if (v == nullptr) return;
    const std::string p = path + key;
    const std::string where = join(what, p);
    if constexpr (Described<T>) {
      require_object(*v, where);
      Reader sub{*v, what, p + ".", {}};
      x.visit_fields(sub);
      refuse_unknown(*v, sub.known, what, sub.path);
    } else if constexpr (HasEnumNames<T>) {
      const std::string name = read_string(*v, where);
      std::vector<const char*> names;
      for (const auto& e : enum_names(x)) {
        if (name == e.name) {
          x = e.value;
          return;
        }
        names.push_back(e.name);
      }
      unknown_enum(name, names, where);
    } else if constexpr (std::is_same_v<T, bool>) {
      x = read_bool(*v, where);
    } else if constexpr (std::is_integral_v<T> && std::is_signed_v<T>) {
      x = static_cast<T>(read_signed(*v, std::numeric_limits<T>::min(), std::numeric_limits<T>::max(), where));
      check_range(static_cast<double>(x), r, what, p);
    } else if constexpr (std::is_integral_v<T>) {
      x = static_cast<T>(read_unsigned(*v, std::numeric_limits<T>::max(), where));
      check_range(static_cast<double>(x), r, what, p);
    } else if constexpr (std::is_floating_point_v<T>) {
      x = static_cast<T>(read_double(*v, where));
      check_range(static_cast<double>(x), r, what, p);
    } else if constexpr (std::is_same_v<T, std::string>) {
      x = read_string(*v, where);
    } else if constexpr (std::is_same_v<T, std::filesystem::path>) {
      x = read_string(*v, where);
    } else if constexpr (std::is_same_v<T, std::vector<int>>) {
      x = read_int_list(*v, where);
      check_list(x, r, what, p);
    } else if constexpr (std::is_same_v<T, std::vector<double>>) {
      x = read_double_list(*v, where);
      check_finite(x, r, what, p);
    } else if constexpr (std::is_same_v<T, nlohmann::json>) {
      read_object(*v, x, where);
    } else {
      static_assert(std::is_same_v<T, Eigen::Isometry3d>, "schema: unsupported field type");
      x = read_matrix(*v, where);
    }
  }
};

struct Checker {
  const std::string& what;
  std::string path;
  template <class T>
  void operator()(const char* key, T& x, Range r = {}) {
    const std::string p = path + key;
    if constexpr (Described<T>) {
      if constexpr (HasValidate<T>) {
        x.validate(join(what, p));  // its ranges and its rules between fields
      } else {
        Checker sub{what, p + "."};
        x.visit_fields(sub);
      }
    } else if constexpr ((std::is_integral_v<T> && !std::is_same_v<T, bool>) || std::is_floating_point_v<T>) {
      check_range(static_cast<double>(x), r, what, p);
    } else if constexpr (std::is_same_v<T, std::vector<int>>) {
      check_list(x, r, what, p);
    } else if constexpr (std::is_same_v<T, std::vector<double>>) {
      check_finite(x, r, what, p);
    } else if constexpr (std::is_same_v<T, Eigen::Isometry3d>) {
      check_matrix(x, what, p);
    }
  }
};

// The walkers read const objects through visit_fields, which takes them non-const (one list for
// reading and writing); Writer and Checker never modify them.
template <class T>
T& unconst(const T& x) {
  return const_cast<T&>(x);
}
}  // namespace detail

/// `o` as a JSON object: every field of the list, nested structs as nested objects.
template <Described T>
void write(const T& o, nlohmann::json& out) {
  detail::make_object(out);
  detail::Writer w{out};
  detail::unconst(o).visit_fields(w);
}

/// Applies the fields present in the object `in` onto `o`: types and ranges checked as they are
/// read; an unknown key (a typo) is an InputError naming it and `what` (the file it came from).
/// Rules between fields are not checked here: call validate() when the whole struct is read.
template <Described T>
void read(const nlohmann::json& in, T& o, const std::string& what) {
  detail::require_object(in, what);
  detail::Reader r{in, what, "", {}};
  o.visit_fields(r);
  detail::refuse_unknown(in, r.known, what, "");
}

/// Checks every field's range; nested structs with a validate(what) are checked by it (the
/// convention: validate(what) calls check(*this, what), then its rules between fields).
/// InputError "<what>: <path> must be <range> (got <x>)".
template <Described T>
void check(const T& o, const std::string& what) {
  detail::Checker c{what, ""};
  detail::unconst(o).visit_fields(c);
}

/// Calls f(path, field) for every leaf field (nested structs flattened, path "poisson.depth"); for
/// tests and documentation.
template <class F>
struct LeafWalker {
  F& f;
  std::string path;
  template <class T>
  void operator()(const char* key, T& x, Range r = {}) {
    if constexpr (Described<T>) {
      LeafWalker sub{f, path + key + "."};
      x.visit_fields(sub);
    } else {
      f(path + key, x, r);
    }
  }
};
template <Described T, class F>
void for_each_leaf(T& o, F&& f) {
  LeafWalker<std::remove_reference_t<F>> w{f, ""};
  o.visit_fields(w);
}

}  // namespace autoscan::schema
