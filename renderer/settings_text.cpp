#include "renderer/settings_text.h"

#include "renderer/error.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <span>

namespace raypack {
namespace {

template <class E>
struct Named {
    E value;
    const char* name;
};

// One table per enum: its names in both directions, and the list for messages.
constexpr Named<KernelKind> kKernelNames[] = {
    {KernelKind::Packet, "packet"}, {KernelKind::Single, "single"}, {KernelKind::Hybrid, "hybrid"}};
constexpr Named<ViewMode> kViewNames[] = {
    {ViewMode::Shaded, "shaded"}, {ViewMode::HeatTraversal, "nodes"}, {ViewMode::HeatIntersections, "tests"}};
constexpr Named<IntersectMode> kIntersectNames[] = {{IntersectMode::Robust, "robust"}, {IntersectMode::Fast, "fast"}};
constexpr Named<ShadowOrder> kShadowOrderNames[] = {
    {ShadowOrder::Nearest, "nearest"}, {ShadowOrder::Tree, "tree"}, {ShadowOrder::Larger, "larger"}};
constexpr Named<HitDistanceMath> kHitDistanceNames[] = {
    {HitDistanceMath::Auto, "auto"}, {HitDistanceMath::Float64, "fp64"}, {HitDistanceMath::FloatPair, "float-pair"}};

template <class E>
const char* nameOf(std::span<const Named<E>> table, E value) {
    for (const Named<E>& entry : table)
        if (entry.value == value) return entry.name;
    return "unknown";
}

template <class E>
std::optional<E> valueOf(std::span<const Named<E>> table, std::string_view name) {
    for (const Named<E>& entry : table)
        if (name == entry.name) return entry.value;
    return std::nullopt;
}

// "a, b or c".
template <class E>
std::string namesOf(std::span<const Named<E>> table) {
    std::string names;
    for (size_t i = 0; i < table.size(); ++i) {
        if (i > 0) names += i + 1 == table.size() ? " or " : ", ";
        names += table[i].name;
    }
    return names;
}

[[noreturn]] void badValue(std::string_view what, std::string_view text, std::string_view expected) {
    throw Error(std::string(what) + ": \"" + std::string(text) + "\" is not " + std::string(expected));
}

// Digits only: std::from_chars takes no sign, no spaces and no "0x", unlike strtoul or sscanf's
// %u (which reads "-1" as 4294967295).
bool parseUint(std::string_view text, uint32_t& out) {
    const char* first = text.data();
    const char* last = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(first, last, out);
    return ec == std::errc() && ptr == last && first != last;
}

bool parseFloat(std::string_view text, float& out) {
    // std::from_chars for floats takes no leading '+'; strtof does (and is locale-dependent, but no
    // raypack program changes the C locale). Leading spaces, which strtof skips, are refused.
    if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
    const std::string copy(text);
    char* end = nullptr;
    out = std::strtof(copy.c_str(), &end);
    return end == copy.c_str() + copy.size() && std::isfinite(out);
}

template <int N>
glm::vec<N, float> parseFloats(std::string_view what, std::string_view text, const char* expected) {
    // Split by hand so that empty components ("1,,2") are caught rather than dropped.
    glm::vec<N, float> v(0.0f);
    size_t start = 0;
    for (int i = 0; i < N; ++i) {
        const size_t end = i < N - 1 ? text.find(',', start) : text.size();
        if (end == std::string_view::npos || !parseFloat(text.substr(start, end - start), v[i]))
            badValue(what, text, expected);
        start = end + 1;
    }
    return v;
}

}  // namespace

const char* toString(KernelKind kind) { return nameOf<KernelKind>(kKernelNames, kind); }
const char* toString(ViewMode mode) { return nameOf<ViewMode>(kViewNames, mode); }
std::optional<KernelKind> parseKernelKind(std::string_view name) { return valueOf<KernelKind>(kKernelNames, name); }
std::optional<ViewMode> parseViewMode(std::string_view name) { return valueOf<ViewMode>(kViewNames, name); }
std::string kernelKindNames() { return namesOf<KernelKind>(kKernelNames); }
std::string viewModeNames() { return namesOf<ViewMode>(kViewNames); }
const char* toString(IntersectMode mode) { return nameOf<IntersectMode>(kIntersectNames, mode); }
std::optional<IntersectMode> parseIntersectMode(std::string_view name) {
    return valueOf<IntersectMode>(kIntersectNames, name);
}
std::string intersectModeNames() { return namesOf<IntersectMode>(kIntersectNames); }
const char* toString(ShadowOrder order) { return nameOf<ShadowOrder>(kShadowOrderNames, order); }
std::optional<ShadowOrder> parseShadowOrder(std::string_view name) {
    return valueOf<ShadowOrder>(kShadowOrderNames, name);
}
std::string shadowOrderNames() { return namesOf<ShadowOrder>(kShadowOrderNames); }
const char* toString(HitDistanceMath math) { return nameOf<HitDistanceMath>(kHitDistanceNames, math); }
std::optional<HitDistanceMath> parseHitDistanceMath(std::string_view name) {
    return valueOf<HitDistanceMath>(kHitDistanceNames, name);
}
std::string hitDistanceMathNames() { return namesOf<HitDistanceMath>(kHitDistanceNames); }

namespace {

template <class E>
E requireName(std::span<const Named<E>> table, std::string_view what, std::string_view text) {
    if (const std::optional<E> value = valueOf<E>(table, text)) return *value;
    throw Error(std::string(what) + ": \"" + std::string(text) + "\" is not " + namesOf<E>(table));
}

}  // namespace

KernelKind requireKernelKind(std::string_view what, std::string_view text) {
    return requireName<KernelKind>(kKernelNames, what, text);
}
ViewMode requireViewMode(std::string_view what, std::string_view text) {
    return requireName<ViewMode>(kViewNames, what, text);
}
IntersectMode requireIntersectMode(std::string_view what, std::string_view text) {
    return requireName<IntersectMode>(kIntersectNames, what, text);
}
ShadowOrder requireShadowOrder(std::string_view what, std::string_view text) {
    return requireName<ShadowOrder>(kShadowOrderNames, what, text);
}
HitDistanceMath requireHitDistanceMath(std::string_view what, std::string_view text) {
    return requireName<HitDistanceMath>(kHitDistanceNames, what, text);
}

PacketShape parsePacketShape(std::string_view what, std::string_view text) {
    const size_t x = text.find_first_of("xX");
    PacketShape shape;
    if (x == std::string_view::npos || !parseUint(text.substr(0, x), shape.width) ||
        !parseUint(text.substr(x + 1), shape.height))
        badValue(what, text, "a packet shape WxH such as 8x4");
    if (shape.width < 1 || shape.height < 1 || shape.width > kMaxPacketSide || shape.height > kMaxPacketSide)
        badValue(what, text, "a packet shape WxH with 1 <= W, H <= " + std::to_string(kMaxPacketSide));
    return shape;
}

std::vector<PacketShape> parsePacketShapes(std::string_view what, std::string_view text) {
    std::vector<PacketShape> shapes;
    for (const std::string& part : splitList(text)) shapes.push_back(parsePacketShape(what, part));
    if (shapes.empty()) badValue(what, text, "a list of packet shapes such as 8x4,4x8");
    return shapes;
}

std::string toString(const PacketShape& shape) {
    return std::to_string(shape.width) + "x" + std::to_string(shape.height);
}

uint32_t HybridMinRaysSpec::resolve(const PacketShape& packet) const {
    return divisor == 0 ? count : std::max(1u, packet.rays() / divisor);
}

std::vector<HybridMinRaysSpec> parseHybridMinRaysList(std::string_view what, std::string_view text) {
    std::vector<HybridMinRaysSpec> list;
    for (const std::string& part : splitList(text)) {
        HybridMinRaysSpec spec;
        spec.text = part;
        const std::string_view view(part);
        const bool ok = view.starts_with("1/") ? parseUint(view.substr(2), spec.divisor) && spec.divisor > 0
                                               : parseUint(view, spec.count);
        if (!ok) badValue(what, part, "a ray count K such as 8 or a share of the packet such as 1/4");
        list.push_back(spec);
    }
    if (list.empty()) badValue(what, text, "a list of ray counts or packet shares such as 1/4,1/8,4");
    return list;
}

std::vector<float> parseHybridVisitRatios(std::string_view what, std::string_view text) {
    std::vector<float> list;
    for (const std::string& part : splitList(text)) {
        float ratio = 0.0f;
        if (!parseFloat(part, ratio) || !(ratio == 0.0f || (ratio >= 1.0f && ratio <= kMaxHybridVisitRatio)))
            badValue(what, part, "a visit ratio: 0 (off) or a number from 1 to 1000");
        list.push_back(ratio);
    }
    if (list.empty()) badValue(what, text, "a list of visit ratios such as 0,2");
    return list;
}

glm::vec3 parseVec3(std::string_view what, std::string_view text) {
    return parseFloats<3>(what, text, "three comma-separated finite numbers x,y,z");
}

glm::vec2 parseVec2(std::string_view what, std::string_view text) {
    return parseFloats<2>(what, text, "two comma-separated finite numbers x,y");
}

float parseFiniteFloat(std::string_view what, std::string_view text) {
    float value = 0.0f;
    if (!parseFloat(text, value)) badValue(what, text, "a finite number");
    return value;
}

float parsePositiveFloat(std::string_view what, std::string_view text) {
    float value = 0.0f;
    if (!parseFloat(text, value) || !(value > 0.0f)) badValue(what, text, "a finite number above 0");
    return value;
}

uint32_t parseHybridPacketsPerGroup(std::string_view what, std::string_view text) {
    if (text == "auto") return kAutoPacketsPerGroup;
    uint32_t value = 0;
    if (!parseUint(text, value) || value == 0 || value > kMaxHybridPacketsPerGroup)
        badValue(what, text, "auto or a count from 1 to " + std::to_string(kMaxHybridPacketsPerGroup));
    return value;
}

uint32_t parsePositiveCount(std::string_view what, std::string_view text) {
    uint32_t value = 0;
    if (!parseUint(text, value) || value == 0) badValue(what, text, "a positive integer");
    return value;
}

std::vector<std::string> splitList(std::string_view text, char separator) {
    std::vector<std::string> parts;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find(separator, start);
        if (end == std::string_view::npos) end = text.size();
        if (end > start) parts.emplace_back(text.substr(start, end - start));
        start = end + 1;
    }
    return parts;
}

}  // namespace raypack
