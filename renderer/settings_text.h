#pragma once
// The text form of every setting, defined once: the CLI's flags, the viewer's flags, its script
// steps and the settings JSON read and write the same names and parse the same values with the
// same rules (a packet shape "-1x4" is refused everywhere, "8x4" means the same everywhere). Each
// parser throws raypack::Error naming what was being read (a flag such as "--packet", or
// "script step 12:packet") and the text, e.g. `--packet: "0x4" is not a packet shape WxH with
// 1 <= W, H <= 1024`.
#include "renderer/bvh.h"
#include "renderer/settings.h"

#include <glm/glm.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace raypack {

// The largest packet side any tracer accepts (the Vulkan kernels' workgroup and the CPU packet
// tracer's tile are both bounded well below it; this bounds what a user can type).
inline constexpr uint32_t kMaxPacketSide = 1024;

// Names: "packet" / "single" / "hybrid"; "shaded" / "nodes" / "tests". toString (renderer/settings.h) gives
// the name the parsers accept, so what one program prints another can read back.
std::optional<KernelKind> parseKernelKind(std::string_view name);
std::optional<ViewMode> parseViewMode(std::string_view name);
std::optional<IntersectMode> parseIntersectMode(std::string_view name);      // "robust" / "fast"
std::optional<ShadowOrder> parseShadowOrder(std::string_view name);          // "nearest" / "tree" / "larger"
std::optional<HitDistanceMath> parseHitDistanceMath(std::string_view name);  // "auto" / "fp64" / "float-pair"
// "packet or single", "shaded, nodes or tests": the valid names, for messages and help texts.
std::string kernelKindNames();
std::string viewModeNames();
std::string intersectModeNames();
std::string shadowOrderNames();
std::string hitDistanceMathNames();
// The same, throwing raypack::Error `WHAT: "TEXT" is not NAMES` for a name the table lacks: one
// message for CLI flags, viewer flags and script steps.
KernelKind requireKernelKind(std::string_view what, std::string_view text);
ViewMode requireViewMode(std::string_view what, std::string_view text);
IntersectMode requireIntersectMode(std::string_view what, std::string_view text);
ShadowOrder requireShadowOrder(std::string_view what, std::string_view text);
HitDistanceMath requireHitDistanceMath(std::string_view what, std::string_view text);

// "WxH" (or "WXH") with 1 <= W, H <= kMaxPacketSide, digits only (no sign, no spaces).
PacketShape parsePacketShape(std::string_view what, std::string_view text);
// A comma-separated list of "WxH" (e.g. "8x4,4x8,5x6"), at least one.
std::vector<PacketShape> parsePacketShapes(std::string_view what, std::string_view text);
std::string toString(const PacketShape& shape);  // "8x4"

// The hybrid kernel's K as the bench sweeps it: a count ("8") or a share of the packet's rays
// ("1/4": K = rays / 4, rounded down, at least 1), so one list serves several packet shapes.
struct HybridMinRaysSpec {
    uint32_t count = 0;    // the count, when divisor is 0
    uint32_t divisor = 0;  // N of "1/N"
    std::string text;      // as given
    uint32_t resolve(const PacketShape& packet) const;
};
// A comma-separated list of them (e.g. "1/4,1/8,0"), at least one.
std::vector<HybridMinRaysSpec> parseHybridMinRaysList(std::string_view what, std::string_view text);
// A comma-separated list of visit ratios, each 0 (off) or in [1, kMaxHybridVisitRatio], at least one.
std::vector<float> parseHybridVisitRatios(std::string_view what, std::string_view text);
// The hybrid kernel's packets per workgroup: "auto" (kAutoPacketsPerGroup) or a count from 1 to
// kMaxHybridPacketsPerGroup.
uint32_t parseHybridPacketsPerGroup(std::string_view what, std::string_view text);

// "x,y,z" / "x,y": that many finite numbers separated by commas, no empty component.
glm::vec3 parseVec3(std::string_view what, std::string_view text);
glm::vec2 parseVec2(std::string_view what, std::string_view text);
// A finite number.
float parseFiniteFloat(std::string_view what, std::string_view text);
// A finite number above 0.
float parsePositiveFloat(std::string_view what, std::string_view text);
// An integer 1 .. 2^32 - 1, digits only.
uint32_t parsePositiveCount(std::string_view what, std::string_view text);

// A comma-separated list (or `separator`), empty entries dropped.
std::vector<std::string> splitList(std::string_view text, char separator = ',');

}  // namespace raypack
