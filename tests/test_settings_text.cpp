// The text form of settings (renderer/settings_text.h), which the CLI's flags, the viewer's flags,
// its script steps and the settings JSON all use: one rule per value, one name table per enum.
#include "renderer/error.h"
#include "renderer/settings_json.h"
#include "renderer/settings_text.h"

#include <gtest/gtest.h>

#include <string>

using namespace raypack;

namespace {

// The message of the Error `f` throws ("" when it throws none).
template <class F>
std::string errorOf(F&& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(SettingsText, PacketShapesAreDigitsXDigitsWithinTheBound) {
    EXPECT_EQ(parsePacketShape("--packet", "8x4"), (PacketShape{8, 4}));
    EXPECT_EQ(parsePacketShape("--packet", "16X16"), (PacketShape{16, 16}));
    EXPECT_EQ(parsePacketShape("--packet", "1x1024"), (PacketShape{1, 1024}));
    // sscanf's %u, which the viewer used, reads "-1" as 4294967295 and " 8" as 8.
    for (const char* bad : {"-1x4", "8x-4", "+8x4", " 8x4", "8x4 ", "0x4", "8x0", "1025x1", "8", "x4", "8x", "8x4x2",
                            "0x8x4", "axb", ""}) {
        const std::string message = errorOf([&] { parsePacketShape("--packet", bad); });
        EXPECT_NE(message, "") << "accepted \"" << bad << "\"";
        EXPECT_EQ(message.rfind("--packet: \"" + std::string(bad) + "\" is not a packet shape", 0), 0u) << message;
    }
    EXPECT_EQ(toString(PacketShape{5, 6}), "5x6");
    EXPECT_EQ(parsePacketShapes("--packets", "8x4,4x8,,5x6"), (std::vector<PacketShape>{{8, 4}, {4, 8}, {5, 6}}));
    EXPECT_NE(errorOf([] { parsePacketShapes("--packets", ","); }), "");
    EXPECT_NE(errorOf([] { parsePacketShapes("--packets", "8x4,-1x4"); }), "");
}

TEST(SettingsText, VectorsNeedEveryComponentFinite) {
    EXPECT_EQ(parseVec3("--eye", "1,-2.5,3e2"), glm::vec3(1.0f, -2.5f, 300.0f));
    EXPECT_EQ(parseVec2("look", "40,-10"), glm::vec2(40.0f, -10.0f));
    for (const char* bad : {"1,,2", "1,2", "1,2,3,4", "1,2,inf", "nan,0,0", "1,2,1e39", "a,b,c", ",1,2", "1,2,", ""})
        EXPECT_NE(errorOf([&] { parseVec3("--eye", bad); }), "") << "accepted \"" << bad << "\"";
    EXPECT_NE(errorOf([] { parseVec2("look", "1,2,3"); }), "");
    EXPECT_EQ(errorOf([] { parseVec3("--at", "1,x,2"); }),
              "--at: \"1,x,2\" is not three comma-separated finite numbers x,y,z");
}

TEST(SettingsText, CountsArePositiveDigits) {
    EXPECT_EQ(parsePositiveCount("leaf-size", "4"), 4u);
    EXPECT_EQ(parsePositiveCount("leaf-size", "4294967295"), 4294967295u);
    for (const char* bad : {"0", "-1", "+3", " 3", "3 ", "4294967296", "3.0", "0x10", ""})
        EXPECT_NE(errorOf([&] { parsePositiveCount("leaf-size", bad); }), "") << "accepted \"" << bad << "\"";
    EXPECT_EQ(parseFiniteFloat("--fov", "45.5"), 45.5f);
    EXPECT_NE(errorOf([] { parseFiniteFloat("--fov", "inf"); }), "");
}

TEST(SettingsText, EveryNameReadsBackAndTheJsonUsesTheSameNames) {
    for (KernelKind kind : {KernelKind::Packet, KernelKind::Single, KernelKind::Hybrid}) {
        EXPECT_EQ(parseKernelKind(toString(kind)), kind);
        RenderSettings settings;
        settings.kernel = kind;
        EXPECT_EQ(toJson(settings)["kernel"], toString(kind));
        EXPECT_EQ(renderSettingsFromJson(toJson(settings)).kernel, kind);
    }
    for (ViewMode mode : {ViewMode::Shaded, ViewMode::HeatTraversal, ViewMode::HeatIntersections}) {
        EXPECT_EQ(parseViewMode(toString(mode)), mode);
        RenderSettings settings;
        settings.view = mode;
        EXPECT_EQ(toJson(settings)["view"], toString(mode));
        EXPECT_EQ(renderSettingsFromJson(toJson(settings)).view, mode);
    }
    for (IntersectMode mode : {IntersectMode::Robust, IntersectMode::Fast}) {
        EXPECT_EQ(parseIntersectMode(toString(mode)), mode);
        RenderSettings settings;
        settings.intersect = mode;
        EXPECT_EQ(toJson(settings)["intersect"], toString(mode));
        EXPECT_EQ(renderSettingsFromJson(toJson(settings)).intersect, mode);
    }
    EXPECT_EQ(intersectModeNames(), "robust or fast");
    for (BvhBuilder builder : kAllBvhBuilders) {
        EXPECT_EQ(findBvhBuilder(toString(builder)), builder);
        EXPECT_EQ(parseBvhBuilder(toString(builder)), builder);
    }
    EXPECT_FALSE(parseKernelKind("Packet"));
    EXPECT_FALSE(parseViewMode(""));
    EXPECT_FALSE(findBvhBuilder("sah"));
    EXPECT_EQ(kernelKindNames(), "packet, single or hybrid");
    EXPECT_EQ(viewModeNames(), "shaded, nodes or tests");
}

// The bench's sweep of the hybrid kernel's split rules (docs/gpu.md): K as a count or a share of the
// packet, visit ratios 0 (off) or 1..1000; and the JSON carries both.
TEST(SettingsText, HybridRuleListsAndTheirJson) {
    const std::vector<HybridMinRaysSpec> ks = parseHybridMinRaysList("--hybrid-min-rays", "1/4,8,0,1/64");
    ASSERT_EQ(ks.size(), 4u);
    EXPECT_EQ(ks[0].resolve({8, 4}), 8u);
    EXPECT_EQ(ks[0].resolve({8, 8}), 16u);
    EXPECT_EQ(ks[0].text, "1/4");
    EXPECT_EQ(ks[1].resolve({16, 16}), 8u);
    EXPECT_EQ(ks[2].resolve({8, 4}), 0u);
    EXPECT_EQ(ks[3].resolve({8, 4}), 1u) << "a share rounds down but stays at least one ray";
    for (const char* bad : {"1/0", "1/", "2/4", "-1", "x", ""})
        EXPECT_NE(errorOf([&] { parseHybridMinRaysList("--hybrid-min-rays", bad); }), "") << "accepted " << bad;
    EXPECT_EQ(parseHybridVisitRatios("--hybrid-visit-ratios", "0,1,2.5"), (std::vector<float>{0.0f, 1.0f, 2.5f}));
    for (const char* bad : {"0.5", "-1", "1001", "nan", "", "two"})
        EXPECT_NE(errorOf([&] { parseHybridVisitRatios("--hybrid-visit-ratios", bad); }), "") << "accepted " << bad;

    RenderSettings settings;
    settings.kernel = KernelKind::Hybrid;
    settings.hybrid = HybridParams{5u, 1.75f};
    const RenderSettings back = renderSettingsFromJson(nlohmann::json::parse(toJson(settings).dump()));
    EXPECT_EQ(back.kernel, KernelKind::Hybrid);
    EXPECT_EQ(back.hybrid, settings.hybrid);
    EXPECT_NE(errorOf([] { renderSettingsFromJson(nlohmann::json::parse(R"({"hybrid": {"visit_ratio": -2}})")); }), "");
    EXPECT_NE(errorOf([] { renderSettingsFromJson(nlohmann::json::parse(R"({"hybrid": {"min_rays": -2}})")); }), "");
}

// Packets per workgroup: "auto" (the device's choice) or a count from 1 to 64, on the command line
// and in the JSON, which writes the default as "auto" and reads it back.
TEST(SettingsText, HybridPacketsPerGroupAreAutoOrACount) {
    EXPECT_EQ(parseHybridPacketsPerGroup("--hybrid-packets-per-group", "auto"), kAutoPacketsPerGroup);
    EXPECT_EQ(parseHybridPacketsPerGroup("--hybrid-packets-per-group", "4"), 4u);
    EXPECT_EQ(parseHybridPacketsPerGroup("--hybrid-packets-per-group", "64"), 64u);
    for (const char* bad : {"0", "65", "-1", "Auto", "", "4x"})
        EXPECT_NE(errorOf([&] { parseHybridPacketsPerGroup("--hybrid-packets-per-group", bad); }), "")
            << "accepted " << bad;

    RenderSettings settings;
    EXPECT_EQ(settings.hybrid.packetsPerGroup, kAutoPacketsPerGroup);
    const nlohmann::json j = toJson(settings);
    EXPECT_EQ(j["hybrid"]["packets_per_group"], "auto");
    EXPECT_EQ(renderSettingsFromJson(j).hybrid.packetsPerGroup, kAutoPacketsPerGroup);
    settings.hybrid.packetsPerGroup = 3;
    EXPECT_EQ(renderSettingsFromJson(nlohmann::json::parse(toJson(settings).dump())).hybrid.packetsPerGroup, 3u);
    for (const char* bad : {R"({"hybrid": {"packets_per_group": 0}})", R"({"hybrid": {"packets_per_group": "four"}})",
                            R"({"hybrid": {"packets_per_group": -1}})"})
        EXPECT_NE(errorOf([&] { renderSettingsFromJson(nlohmann::json::parse(bad)); }), "") << "accepted " << bad;
}

TEST(SettingsText, ListsDropEmptyEntries) {
    EXPECT_EQ(splitList("a,,b,"), (std::vector<std::string>{"a", "b"}));
    EXPECT_EQ(splitList("a;b", ';'), (std::vector<std::string>{"a", "b"}));
    EXPECT_TRUE(splitList("").empty());
}
