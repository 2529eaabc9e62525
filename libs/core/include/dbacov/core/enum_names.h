// One table of names per enum: the text form that flags, JSON files, CSV columns and Python
// keywords use. An enum opts in by specializing EnumNames<E> with its `what` (for messages) and
// its `entries`; parseEnum / toString / enumNames then serve every reader and writer, so that no
// name is spelled twice.
#pragma once

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace dbacov {

/// Specialize for each enum E:
///   template <> struct EnumNames<E> {
///     static constexpr const char* what = "gauge";
///     static constexpr std::array<std::pair<E, const char*>, N> entries{{...}};
///   };
template <class E>
struct EnumNames;

/// Every name of E in table order.
template <class E>
std::vector<std::string> enumNames() {
  std::vector<std::string> names;
  for (const auto& e : EnumNames<E>::entries) names.emplace_back(e.second);
  return names;
}

/// "a, b or c" over the names of E (for messages and help texts).
template <class E>
std::string enumNameList() {
  const auto names = enumNames<E>();
  std::string s;
  for (std::size_t i = 0; i < names.size(); ++i)
    s += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i];
  return s;
}

/// The value named `name`. Throws std::invalid_argument "unknown <what> '<name>', expected ...".
template <class E>
E parseEnum(std::string_view name) {
  for (const auto& e : EnumNames<E>::entries)
    if (name == e.second) return e.first;
  throw std::invalid_argument("unknown " + std::string(EnumNames<E>::what) + " '" +
                              std::string(name) + "', expected " + enumNameList<E>());
}

/// The name of `value`. Throws std::invalid_argument for a value outside the table.
template <class E>
const char* toString(E value) {
  for (const auto& e : EnumNames<E>::entries)
    if (e.first == value) return e.second;
  throw std::invalid_argument(std::string("invalid ") + EnumNames<E>::what + " value " +
                              std::to_string(static_cast<long long>(value)));
}

}  // namespace dbacov
