#include "renderer/settings_json.h"

#include "renderer/progressive.h"
#include "renderer/settings_text.h"

#include "renderer/error.h"

#include <cmath>
#include <fstream>
#include <sstream>

namespace raypack {
namespace {

using nlohmann::json;

json toJson(const glm::vec3& v) { return json::array({v.x, v.y, v.z}); }

// A value as it appears in an error message: its JSON, cut to 60 characters so that a huge value
// still gives a one-line error of readable length.
std::string shortDump(const json& value) {
    std::string text = value.dump();
    if (text.size() > 60) text = text.substr(0, 57) + "...";
    return text;
}

[[noreturn]] void badKey(const std::string& key, const std::string& what) {
    throw Error("settings JSON: \"" + key + "\" " + what);
}

// Readers for one optional key: leave `out` as it is when the key is absent.
const json* find(const json& object, const char* key) {
    auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
}

void readFloat(const json& object, const char* key, const std::string& path, float& out) {
    const json* value = find(object, key);
    if (!value) return;
    if (!value->is_number()) badKey(path + key, "must be a number, got " + shortDump(*value));
    const double d = value->get<double>();
    if (!std::isfinite(d)) badKey(path + key, "must be finite");
    out = float(d);
}

void readUint(const json& object, const char* key, const std::string& path, uint32_t& out) {
    const json* value = find(object, key);
    if (!value) return;
    if (!value->is_number_integer() || value->get<int64_t>() < 0 || value->get<int64_t>() > int64_t(UINT32_MAX))
        badKey(path + key, "must be a non-negative integer, got " + shortDump(*value));
    out = uint32_t(value->get<int64_t>());
}

void readBool(const json& object, const char* key, const std::string& path, bool& out) {
    const json* value = find(object, key);
    if (!value) return;
    if (!value->is_boolean()) badKey(path + key, "must be true or false, got " + shortDump(*value));
    out = value->get<bool>();
}

void readVec3(const json& object, const char* key, const std::string& path, glm::vec3& out) {
    const json* value = find(object, key);
    if (!value) return;
    if (!value->is_array() || value->size() != 3)
        badKey(path + key, "must be an array of 3 numbers, got " + shortDump(*value));
    for (int i = 0; i < 3; ++i) {
        const json& c = (*value)[i];
        if (!c.is_number() || !std::isfinite(c.get<double>()))
            badKey(path + key, "must be an array of 3 finite numbers, got " + shortDump(*value));
        out[i] = float(c.get<double>());
    }
}

const json* readObject(const json& object, const char* key, const std::string& path) {
    const json* value = find(object, key);
    if (value && !value->is_object()) badKey(path + key, "must be an object, got " + shortDump(*value));
    return value;
}

std::string readString(const json& object, const char* key, const std::string& path) {
    const json* value = find(object, key);
    if (!value) return {};
    if (!value->is_string()) badKey(path + key, "must be a string, got " + shortDump(*value));
    return value->get<std::string>();
}

void requireObject(const json& json, const char* what) {
    if (!json.is_object())
        throw Error(std::string("settings JSON: the ") + what + " must be a JSON object, got " + json.type_name());
}

// nlohmann's messages quote the text last read, which may be long or hold a newline.
std::string oneLine(std::string text) {
    for (char& c : text)
        if (c == '\n' || c == '\r') c = ' ';
    if (text.size() > 200) text = text.substr(0, 197) + "...";
    return text;
}

}  // namespace

nlohmann::json hybridPacketsPerGroupJson(uint32_t packetsPerGroup) {
    return packetsPerGroup == kAutoPacketsPerGroup ? json("auto") : json(packetsPerGroup);
}

nlohmann::json toJson(const RenderSettings& s) {
    json j;
    j["width"] = s.width;
    j["height"] = s.height;
    j["camera"] = {{"eye", toJson(s.camera.eye)},
                   {"at", toJson(s.camera.at)},
                   {"up", toJson(s.camera.up)},
                   {"fov_y_degrees", s.camera.fovYDegrees}};
    j["light_height"] = s.lightHeight;
    j["shadows"] = s.shadows;
    j["phong"] = {{"ambient", s.phong.ambient},
                  {"diffuse", s.phong.diffuse},
                  {"specular", s.phong.specular},
                  {"shininess", s.phong.shininess}};
    j["background"] = toJson(s.background);
    j["intersect"] = toString(s.intersect);
    j["shadow_order"] = toString(s.shadowOrder);
    j["hit_distance"] = toString(s.hitDistance);
    j["kernel"] = toString(s.kernel);
    j["packet"] = {{"width", s.packet.width}, {"height", s.packet.height}};
    j["single_group"] = {{"width", s.singleGroup.width}, {"height", s.singleGroup.height}};
    j["single_shadow_group"] = {{"width", s.singleShadowGroup.width}, {"height", s.singleShadowGroup.height}};
    j["hybrid"] = {{"min_rays", s.hybrid.minRays},
                   {"visit_ratio", s.hybrid.visitRatio},
                   {"packets_per_group", hybridPacketsPerGroupJson(s.hybrid.packetsPerGroup)}};
    j["bvh_width"] = s.bvhWidth;
    j["collect_counters"] = s.collectCounters;
    j["view"] = toString(s.view);
    j["heat_full_scale"] = s.heatFullScale;
    return j;
}

nlohmann::json toJson(const BvhBuildOptions& o) {
    return {
        {"builder", toString(o.builder)},          {"leaf_size", o.leafSize},     {"traversal_cost", o.traversalCost},
        {"intersection_cost", o.intersectionCost}, {"bin_count", o.binCount},     {"split_alpha", o.splitAlpha},
        {"split_budget", o.splitBudget},           {"ploc_radius", o.plocRadius}, {"treelet_rounds", o.treeletRounds},
        {"treelet_gamma", o.treeletGamma},         {"top_rebuild", o.topRebuild}};
}

nlohmann::json toJson(const RenderSetup& setup) {
    json j = toJson(setup.settings);
    j["scene"] = setup.scene;
    j["bvh"] = toJson(setup.bvh);
    j["samples_per_pixel"] = setup.samples;
    j["sample_pattern"] = kSamplePatternName;
    j["resolution_scale"] = setup.resolutionScale;
    return j;
}

RenderSettings renderSettingsFromJson(const nlohmann::json& j) {
    requireObject(j, "settings");
    RenderSettings s;
    readUint(j, "width", "", s.width);
    readUint(j, "height", "", s.height);
    if (s.width == 0 || s.height == 0) badKey("width/height", "must both be at least 1");
    // The command line's limit (render --width/--height), which --from must not bypass.
    if (s.width > kMaxImageSide || s.height > kMaxImageSide)
        badKey("width/height", "must both be at most " + std::to_string(kMaxImageSide) + ", got " +
                                   std::to_string(s.width) + "x" + std::to_string(s.height));
    if (const json* camera = readObject(j, "camera", "")) {
        readVec3(*camera, "eye", "camera.", s.camera.eye);
        readVec3(*camera, "at", "camera.", s.camera.at);
        readVec3(*camera, "up", "camera.", s.camera.up);
        readFloat(*camera, "fov_y_degrees", "camera.", s.camera.fovYDegrees);
        if (!(s.camera.fovYDegrees > 0.0f && s.camera.fovYDegrees < 180.0f))
            badKey("camera.fov_y_degrees", "must be in (0, 180) degrees");
    }
    readFloat(j, "light_height", "", s.lightHeight);
    readFloat(j, "heat_full_scale", "", s.heatFullScale);
    if (!(s.heatFullScale >= 0.0f) || !std::isfinite(s.heatFullScale))
        badKey("heat_full_scale", "must be a finite number >= 0 (0: the view's default)");
    readBool(j, "shadows", "", s.shadows);
    if (const json* phong = readObject(j, "phong", "")) {
        readFloat(*phong, "ambient", "phong.", s.phong.ambient);
        readFloat(*phong, "diffuse", "phong.", s.phong.diffuse);
        readFloat(*phong, "specular", "phong.", s.phong.specular);
        readFloat(*phong, "shininess", "phong.", s.phong.shininess);
    }
    readVec3(j, "background", "", s.background);
    if (const std::string intersect = readString(j, "intersect", ""); !intersect.empty()) {
        const auto parsed = parseIntersectMode(intersect);
        if (!parsed) badKey("intersect", "must be " + intersectModeNames() + ", got \"" + intersect + "\"");
        s.intersect = *parsed;
    }
    if (const std::string order = readString(j, "shadow_order", ""); !order.empty()) {
        const auto parsed = parseShadowOrder(order);
        if (!parsed) badKey("shadow_order", "must be " + shadowOrderNames() + ", got \"" + order + "\"");
        s.shadowOrder = *parsed;
    }
    if (const std::string math = readString(j, "hit_distance", ""); !math.empty()) {
        const auto parsed = parseHitDistanceMath(math);
        if (!parsed) badKey("hit_distance", "must be " + hitDistanceMathNames() + ", got \"" + math + "\"");
        s.hitDistance = *parsed;
    }
    if (const std::string kernel = readString(j, "kernel", ""); !kernel.empty()) {
        const auto parsed = parseKernelKind(kernel);
        if (!parsed) badKey("kernel", "must be " + kernelKindNames() + ", got \"" + kernel + "\"");
        s.kernel = *parsed;
    }
    if (const json* packet = readObject(j, "packet", "")) {
        readUint(*packet, "width", "packet.", s.packet.width);
        readUint(*packet, "height", "packet.", s.packet.height);
        if (s.packet.width == 0 || s.packet.height == 0) badKey("packet", "width and height must both be at least 1");
    }
    for (auto [key, group] :
         {std::pair{"single_group", &s.singleGroup}, std::pair{"single_shadow_group", &s.singleShadowGroup}}) {
        if (const json* g = readObject(j, key, "")) {
            readUint(*g, "width", std::string(key) + ".", group->width);
            readUint(*g, "height", std::string(key) + ".", group->height);
            if (group->width == 0 || group->height == 0) badKey(key, "width and height must both be at least 1");
        }
    }
    if (const json* hybrid = readObject(j, "hybrid", "")) {
        readUint(*hybrid, "min_rays", "hybrid.", s.hybrid.minRays);
        readFloat(*hybrid, "visit_ratio", "hybrid.", s.hybrid.visitRatio);
        if (!(s.hybrid.visitRatio >= 0.0f && s.hybrid.visitRatio <= kMaxHybridVisitRatio))
            badKey("hybrid", "visit_ratio must be 0 (off) or a ratio up to 1000");
        // "auto" (the device's choice, kAutoPacketsPerGroup) or a count of at least 1.
        if (const json* packets = find(*hybrid, "packets_per_group"); packets && packets->is_string()) {
            if (packets->get<std::string>() != "auto")
                badKey("hybrid.packets_per_group",
                       "must be \"auto\" or a count of at least 1, got " + shortDump(*packets));
            s.hybrid.packetsPerGroup = kAutoPacketsPerGroup;
        } else {
            readUint(*hybrid, "packets_per_group", "hybrid.", s.hybrid.packetsPerGroup);
            if (s.hybrid.packetsPerGroup == 0)
                badKey("hybrid.packets_per_group", "must be \"auto\" or a count of at least 1, got 0");
        }
    }
    readUint(j, "bvh_width", "", s.bvhWidth);
    if (s.bvhWidth != 2 && s.bvhWidth != 8)
        badKey("bvh_width", "must be 2 (the binary tree) or 8 (the compressed 8-wide tree)");
    readBool(j, "collect_counters", "", s.collectCounters);
    if (const std::string view = readString(j, "view", ""); !view.empty()) {
        const auto parsed = parseViewMode(view);
        if (!parsed) badKey("view", "must be \"shaded\", \"nodes\" or \"tests\", got \"" + view + "\"");
        s.view = *parsed;
    }
    return s;
}

BvhBuildOptions bvhBuildOptionsFromJson(const nlohmann::json& j) {
    requireObject(j, "bvh options");
    BvhBuildOptions o;
    if (const std::string builder = readString(j, "builder", "bvh."); !builder.empty()) {
        const auto parsed = findBvhBuilder(builder);
        if (!parsed) badKey("bvh.builder", "names no known builder: \"" + builder + "\"");
        o.builder = *parsed;
    }
    readUint(j, "leaf_size", "bvh.", o.leafSize);
    if (o.leafSize == 0 || o.leafSize > kMaxLeafPrimitives)
        badKey("bvh.leaf_size", "must be in 1.." + std::to_string(kMaxLeafPrimitives));
    readFloat(j, "traversal_cost", "bvh.", o.traversalCost);
    readFloat(j, "intersection_cost", "bvh.", o.intersectionCost);
    readUint(j, "bin_count", "bvh.", o.binCount);
    if (o.binCount < 2 || o.binCount > 256) badKey("bvh.bin_count", "must be in 2..256");
    readFloat(j, "split_alpha", "bvh.", o.splitAlpha);
    if (!(o.splitAlpha >= 0.0f && o.splitAlpha <= 1.0f)) badKey("bvh.split_alpha", "must be in 0..1");
    readFloat(j, "split_budget", "bvh.", o.splitBudget);
    if (!(o.splitBudget >= 1.0f && o.splitBudget <= 4.0f)) badKey("bvh.split_budget", "must be in 1..4");
    readUint(j, "ploc_radius", "bvh.", o.plocRadius);
    if (o.plocRadius > kMaxPlocRadius)
        badKey("bvh.ploc_radius", "must be in 1.." + std::to_string(kMaxPlocRadius) + ", or 0 for the builder's own");
    readUint(j, "treelet_rounds", "bvh.", o.treeletRounds);
    if (o.treeletRounds > kMaxTreeletRounds)
        badKey("bvh.treelet_rounds", "must be in 0.." + std::to_string(kMaxTreeletRounds));
    readUint(j, "treelet_gamma", "bvh.", o.treeletGamma);
    if (o.treeletGamma < kMinTreeletGamma)
        badKey("bvh.treelet_gamma", "must be at least " + std::to_string(kMinTreeletGamma));
    readUint(j, "top_rebuild", "bvh.", o.topRebuild);
    if (!(o.traversalCost >= 0.0f) || !(o.intersectionCost > 0.0f))
        badKey("bvh", "traversal_cost must be >= 0 and intersection_cost > 0");
    return o;
}

RenderSetup renderSetupFromJson(const nlohmann::json& j) {
    RenderSetup setup;
    setup.settings = renderSettingsFromJson(j);
    setup.scene = readString(j, "scene", "");
    if (const json* bvh = readObject(j, "bvh", "")) setup.bvh = bvhBuildOptionsFromJson(*bvh);
    readUint(j, "samples_per_pixel", "", setup.samples);
    if (setup.samples == 0 || setup.samples > kMaxSamplesPerPixel)
        badKey("samples_per_pixel", "must be 1.." + std::to_string(kMaxSamplesPerPixel));
    if (j.contains("sample_pattern") && readString(j, "sample_pattern", "") != kSamplePatternName)
        badKey("sample_pattern", std::string("must be \"") + kSamplePatternName + "\" (the only pattern raypack has)");
    readUint(j, "resolution_scale", "", setup.resolutionScale);
    if (setup.resolutionScale == 0 || setup.resolutionScale > 64) badKey("resolution_scale", "must be 1..64");
    return setup;
}

nlohmann::json readJsonFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(path + ": cannot open the JSON file");
    std::stringstream text;
    text << in.rdbuf();
    if (in.bad()) throw Error(path + ": cannot read the JSON file");
    // Nesting is bounded while parsing, before a deep value exists: raypack's files nest 3 levels,
    // and 200,000 levels would overflow the stack of anything that walks the value recursively.
    constexpr int kMaxDepth = 64;
    const json::parser_callback_t limitDepth = [&](int depth, json::parse_event_t event, json&) {
        if (depth > kMaxDepth &&
            (event == json::parse_event_t::object_start || event == json::parse_event_t::array_start))
            throw Error(path + ": JSON nested more than " + std::to_string(kMaxDepth) + " levels deep");
        return true;
    };
    try {
        return json::parse(text.str(), limitDepth);
    } catch (const json::parse_error& e) {
        throw Error(path + ": not valid JSON at byte " + std::to_string(e.byte) + ": " + oneLine(e.what()));
    } catch (const json::exception& e) {
        // e.g. out_of_range.406 for a number such as 1e400 that no double holds.
        throw Error(path + ": not valid JSON: " + oneLine(e.what()));
    }
}

void writeJsonFile(const std::string& path, const nlohmann::json& json) {
    std::ofstream out(path, std::ios::binary);
    if (!out) throw Error(path + ": cannot create the JSON file");
    out << json.dump(2) << '\n';
    out.close();
    if (!out) throw Error(path + ": cannot write the JSON file");
}

}  // namespace raypack
