#pragma once
// Parsing of the CLI's compound argument values ("x,y,z", "WxH", lists). Each throws
// raypack::Error naming the flag and the value when the value is malformed.
#include "renderer/settings.h"

#include <glm/glm.hpp>

#include <string>
#include <vector>

namespace raypack::cli {

// "x,y,z" with three finite numbers.
glm::vec3 parseVec3(const std::string& flag, const std::string& text);
// "WxH" with 1 <= W, H <= 1024 (e.g. "8x4").
PacketShape parsePacketShape(const std::string& flag, const std::string& text);
// Comma-separated "WxH" list (e.g. "8x4,4x8,5x6").
std::vector<PacketShape> parsePacketShapes(const std::string& flag, const std::string& text);
// Comma-separated list, empty entries dropped.
std::vector<std::string> splitList(const std::string& text, char separator = ',');

std::string toString(const PacketShape& shape);  // "8x4"

}  // namespace raypack::cli
