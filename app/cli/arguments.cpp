#include "app/cli/arguments.h"

#include "renderer/error.h"

#include <charconv>
#include <cmath>
#include <cstdlib>

namespace raypack::cli {
namespace {

[[noreturn]] void badValue(const std::string& flag, const std::string& text, const char* expected) {
    throw Error(flag + ": \"" + text + "\" is not " + expected);
}

bool parseFloat(const std::string& text, float& out) {
    // std::from_chars for floats accepts no leading '+' or spaces; strtof is locale-dependent but
    // the CLI never changes the C locale.
    if (text.empty()) return false;
    char* end = nullptr;
    out = std::strtof(text.c_str(), &end);
    return end == text.c_str() + text.size() && std::isfinite(out);
}

bool parseUint(const std::string& text, uint32_t& out) {
    const char* first = text.data();
    const char* last = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(first, last, out);
    return ec == std::errc() && ptr == last && first != last;
}

}  // namespace

std::vector<std::string> splitList(const std::string& text, char separator) {
    std::vector<std::string> parts;
    size_t start = 0;
    while (start <= text.size()) {
        size_t end = text.find(separator, start);
        if (end == std::string::npos) end = text.size();
        if (end > start) parts.push_back(text.substr(start, end - start));
        start = end + 1;
    }
    return parts;
}

glm::vec3 parseVec3(const std::string& flag, const std::string& text) {
    // Split by hand so that empty components ("1,,2") are caught rather than dropped.
    glm::vec3 v;
    size_t start = 0;
    for (int i = 0; i < 3; ++i) {
        const size_t end = i < 2 ? text.find(',', start) : text.size();
        if (end == std::string::npos) badValue(flag, text, "three comma-separated numbers x,y,z");
        if (!parseFloat(text.substr(start, end - start), v[i]))
            badValue(flag, text, "three comma-separated finite numbers x,y,z");
        start = end + 1;
    }
    return v;
}

PacketShape parsePacketShape(const std::string& flag, const std::string& text) {
    const size_t x = text.find_first_of("xX");
    PacketShape shape;
    if (x == std::string::npos || !parseUint(text.substr(0, x), shape.width) ||
        !parseUint(text.substr(x + 1), shape.height))
        badValue(flag, text, "a packet shape WxH such as 8x4");
    if (shape.width < 1 || shape.height < 1 || shape.width > 1024 || shape.height > 1024)
        badValue(flag, text, "a packet shape with 1 <= W, H <= 1024");
    return shape;
}

std::vector<PacketShape> parsePacketShapes(const std::string& flag, const std::string& text) {
    std::vector<PacketShape> shapes;
    for (const std::string& part : splitList(text)) shapes.push_back(parsePacketShape(flag, part));
    if (shapes.empty()) badValue(flag, text, "a list of packet shapes such as 8x4,4x8");
    return shapes;
}

std::string toString(const PacketShape& shape) {
    return std::to_string(shape.width) + "x" + std::to_string(shape.height);
}

}  // namespace raypack::cli
