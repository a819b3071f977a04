// The names users type for the augmentation's options (augmentation.hpp): map kinds,
// depth values and sampling modes, each listed once below; parsing, printing and the
// lists the CLI's choices, the Python bindings and the messages read follow from it.
#include <array>
#include <utility>

#include "fishcam/augment/augmentation.hpp"

namespace fishcam {
namespace {

// An option's values and their names, in the order the lists give them.
template <class Enum, std::size_t N>
struct NameTable {
  std::array<std::pair<Enum, std::string_view>, N> entries;

  std::optional<Enum> parse(std::string_view name) const {
    for (const auto& [value, text] : entries) {
      if (text == name) return value;
    }
    return std::nullopt;
  }
  std::string_view name(Enum value) const {
    for (const auto& [known, text] : entries) {
      if (known == value) return text;
    }
    return "?";  // every enumerator is listed: not reached
  }
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& entry : entries) out.emplace_back(entry.second);
    return out;
  }
};

constexpr NameTable<MapKind, 2> kMapKinds{{{{MapKind::sampling, "sampling"}, {MapKind::geometric, "geometric"}}}};
constexpr NameTable<DepthValues, 2> kDepthValues{{{{DepthValues::range, "range"}, {DepthValues::z, "z"}}}};
constexpr NameTable<Sampling, 2> kSamplings{{{{Sampling::grid, "grid"}, {Sampling::exact, "exact"}}}};

}  // namespace

std::optional<MapKind> parse_map_kind(std::string_view name) { return kMapKinds.parse(name); }
std::string_view to_string(MapKind kind) { return kMapKinds.name(kind); }
const std::vector<std::string>& map_kind_names() {
  static const std::vector<std::string> names = kMapKinds.names();
  return names;
}

std::optional<DepthValues> parse_depth_values(std::string_view name) { return kDepthValues.parse(name); }
std::string_view to_string(DepthValues values) { return kDepthValues.name(values); }
const std::vector<std::string>& depth_values_names() {
  static const std::vector<std::string> names = kDepthValues.names();
  return names;
}

std::optional<Sampling> parse_sampling(std::string_view name) { return kSamplings.parse(name); }
std::string_view to_string(Sampling sampling) { return kSamplings.name(sampling); }
const std::vector<std::string>& sampling_names() {
  static const std::vector<std::string> names = kSamplings.names();
  return names;
}

}  // namespace fishcam
