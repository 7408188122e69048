// PNG files, the image comparison, and the hits file (RPKHITS1, docs/hits-format.md).
#include "renderer/error.h"
#include "renderer/hits_io.h"
#include "renderer/image.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

namespace {

using namespace raypack;

class TempDir : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ =
            std::filesystem::temp_directory_path() / ("raypack_test_image_" + std::to_string(::getpid()) + "_" +
                                                      ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }
    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    std::filesystem::path dir_;
};

Image randomImage(uint32_t width, uint32_t height, uint32_t seed) {
    std::mt19937 rng(seed);
    Image image;
    image.width = width;
    image.height = height;
    image.rgba.resize(size_t(width) * height);
    for (uint32_t& p : image.rgba) p = rng();
    return image;
}

std::string expectErrorMentioning(const std::function<void()>& f, const std::string& text) {
    try {
        f();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(text), std::string::npos)
            << "message \"" << e.what() << "\" does not mention \"" << text << "\"";
        return e.what();
    }
    ADD_FAILURE() << "no raypack::Error thrown";
    return {};
}

using Png = TempDir;

TEST_F(Png, RoundTripIsExactIncludingAlpha) {
    const Image image = randomImage(37, 23, 1);
    writePng(path("a.png"), image);
    const Image back = readPng(path("a.png"));
    EXPECT_EQ(back.width, 37u);
    EXPECT_EQ(back.height, 23u);
    EXPECT_EQ(back.rgba, image.rgba);
}

TEST_F(Png, ChannelOrderInMemoryIsRgba) {
    // R in the low byte: a red pixel reads back red from the file's first channel.
    Image image{2, 1, {0xFF0000FFu, 0xFFFF0000u}};
    writePng(path("rb.png"), image);
    const Image back = readPng(path("rb.png"));
    EXPECT_EQ(back.rgba[0] & 0xFFu, 0xFFu);
    EXPECT_EQ((back.rgba[1] >> 16) & 0xFFu, 0xFFu);
}

TEST_F(Png, ErrorsNameTheFile) {
    expectErrorMentioning([&] { readPng(path("missing.png")); }, "missing.png");
    std::ofstream(path("junk.png")) << "not a png at all";
    expectErrorMentioning([&] { readPng(path("junk.png")); }, "junk.png");
    expectErrorMentioning([&] { writePng(path("no/such/dir/x.png"), randomImage(2, 2, 3)); }, "x.png");
    expectErrorMentioning([&] { writePng(path("bad.png"), 4, 4, std::vector<uint32_t>(3)); }, "bad.png");
}

TEST(Diff, IdenticalImages) {
    const Image a = randomImage(16, 16, 5);
    const ImageDiff diff = diffImages(a, a);
    EXPECT_EQ(diff.differingPixels, 0u);
    EXPECT_EQ(diff.pixels, 256u);
    EXPECT_EQ(diff.differingShare, 0.0);
    EXPECT_EQ(diff.maxChannelDifference, 0u);
    EXPECT_TRUE(std::isinf(diff.psnr));
}

TEST(Diff, CountsShareMaxAndPsnrByHand) {
    // 4x1 grey images; pixel 1 differs by 10 in R, pixel 3 by 2 in G and 40 in alpha.
    Image a{4, 1, {0xFF808080u, 0xFF808080u, 0xFF808080u, 0xFF808080u}};
    Image b = a;
    b.rgba[1] = 0xFF80808Au;  // R 0x8A = 0x80 + 10
    b.rgba[3] = 0xD7808280u;  // G + 2, A 0xD7 = 0xFF - 40
    const ImageDiff strict = diffImages(a, b, 0);
    EXPECT_EQ(strict.differingPixels, 2u);
    EXPECT_DOUBLE_EQ(strict.differingShare, 0.5);
    EXPECT_EQ(strict.maxChannelDifference, 40u);
    // PSNR over R, G, B: MSE = (100 + 4) / (3 * 4).
    EXPECT_NEAR(strict.psnr, 10.0 * std::log10(255.0 * 255.0 / (104.0 / 12.0)), 1e-9);
    // The difference image marks differing pixels red.
    EXPECT_EQ(strict.difference.rgba[1], 0xFF0000FFu);
    EXPECT_EQ(strict.difference.rgba[3], 0xFF0000FFu);
    EXPECT_NE(strict.difference.rgba[0], 0xFF0000FFu);
    // A threshold of 10 tolerates pixel 1 (difference 10) but not pixel 3 (alpha 40).
    const ImageDiff tolerant = diffImages(a, b, 10);
    EXPECT_EQ(tolerant.differingPixels, 1u);
    EXPECT_EQ(diffImages(a, b, 40).differingPixels, 0u);
}

TEST(Diff, SizeMismatchNamesBothImages) {
    expectErrorMentioning([] { diffImages(randomImage(4, 4, 1), randomImage(4, 5, 1), 0, "left.png", "right.png"); },
                          "right.png");
}

using Hits = TempDir;

HitsFile sampleHits() {
    HitsFile hits;
    hits.width = 3;
    hits.height = 2;
    hits.light = glm::vec3(1.5f, -2.0f, 1e10f);
    for (uint32_t i = 0; i < 6; ++i) {
        HitRecord r{};
        r.orgX = float(i);
        r.orgY = -1.0f;
        r.orgZ = 0.25f;
        r.dirX = 0.0f;
        r.dirY = -0.0f;
        r.dirZ = 1.0f;
        const bool miss = i == 4;
        r.t = miss ? std::numeric_limits<float>::infinity() : 0.5f * float(i + 1);
        r.prim = miss ? gpu::kNoHit : 1000u + i;
        r.shadow = miss ? gpu::kShadowNone : i % 2;
        r.reserved = 0;
        hits.records.push_back(r);
    }
    return hits;
}

TEST_F(Hits, RoundTripAndExactLayout) {
    const HitsFile hits = sampleHits();
    writeHits(path("h.bin"), hits);
    EXPECT_EQ(std::filesystem::file_size(path("h.bin")), 32u + 6u * 40u);
    const HitsFile back = readHits(path("h.bin"));
    EXPECT_EQ(back.width, 3u);
    EXPECT_EQ(back.height, 2u);
    EXPECT_EQ(back.light, hits.light);
    ASSERT_EQ(back.records.size(), 6u);
    EXPECT_EQ(std::memcmp(back.records.data(), hits.records.data(), 6 * sizeof(HitRecord)), 0);

    // The bytes themselves, as docs/hits-format.md gives them (little-endian).
    std::ifstream in(path("h.bin"), std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 8), "RPKHITS1");
    EXPECT_EQ(bytes[8], 3);   // width, low byte first
    EXPECT_EQ(bytes[12], 2);  // height
    auto word = [&](size_t offset) {
        return uint32_t(bytes[offset]) | uint32_t(bytes[offset + 1]) << 8 | uint32_t(bytes[offset + 2]) << 16 |
               uint32_t(bytes[offset + 3]) << 24;
    };
    EXPECT_EQ(word(16), 0x3FC00000u);                // light.x = 1.5f
    EXPECT_EQ(word(28), 0u);                         // reserved
    const size_t record1 = 32 + 40;                  // second record
    EXPECT_EQ(word(record1 + 0), 0x3F800000u);       // org.x = 1.0f
    EXPECT_EQ(word(record1 + 24), 0x3F800000u);      // t = 1.0f
    EXPECT_EQ(word(record1 + 28), 1001u);            // prim
    EXPECT_EQ(word(record1 + 32), 1u);               // shadow: occluded
    EXPECT_EQ(word(32 + 4 * 40 + 24), 0x7F800000u);  // the miss: t = +inf
    EXPECT_EQ(word(32 + 4 * 40 + 28), 0xFFFFFFFFu);  // prim = none
    EXPECT_EQ(word(32 + 4 * 40 + 32), 2u);           // no shadow ray
}

TEST_F(Hits, WriteFromAFrame) {
    const HitsFile hits = sampleHits();
    Frame frame;
    frame.width = hits.width;
    frame.height = hits.height;
    frame.light = hits.light;
    frame.hits = hits.records;
    writeHits(path("f.bin"), frame);
    EXPECT_EQ(readHits(path("f.bin")).records.size(), 6u);
    frame.hits.pop_back();
    expectErrorMentioning([&] { writeHits(path("g.bin"), frame); }, "g.bin");
}

// Writes `bytes` to a file and expects readHits to reject it with `text` in the message.
void expectRejected(const std::string& file, const std::vector<unsigned char>& bytes, const std::string& text) {
    std::ofstream(file, std::ios::binary)
        .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    const std::string message = expectErrorMentioning([&] { readHits(file); }, text);
    EXPECT_NE(message.find(std::filesystem::path(file).filename().string()), std::string::npos) << message;
}

TEST_F(Hits, RejectsBadFiles) {
    writeHits(path("good.bin"), sampleHits());
    std::ifstream in(path("good.bin"), std::ios::binary);
    const std::vector<unsigned char> good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

    expectErrorMentioning([&] { readHits(path("absent.bin")); }, "absent.bin");
    expectRejected(path("empty.bin"), {}, "truncated");
    expectRejected(path("short_header.bin"), {good.begin(), good.begin() + 20}, "truncated");
    std::vector<unsigned char> bad = good;
    bad[0] = 'X';
    expectRejected(path("magic.bin"), bad, "magic");
    bad = good;
    bad[28] = 1;
    expectRejected(path("reserved.bin"), bad, "reserved");
    expectRejected(path("truncated.bin"), {good.begin(), good.end() - 1}, "bytes");
    bad = good;
    bad.push_back(0);
    expectRejected(path("long.bin"), bad, "bytes");
    // A header claiming far more records than the file holds: rejected before allocating.
    bad = good;
    bad[8] = bad[9] = bad[10] = bad[11] = 0xFF;
    bad[12] = bad[13] = bad[14] = bad[15] = 0xFF;
    expectRejected(path("huge.bin"), bad, "bytes");
    bad = good;
    bad[32 + 40 + 32] = 7;  // shadow state of record 1
    expectRejected(path("shadow.bin"), bad, "shadow state 7");
    bad = good;
    bad[32 + 2 * 40 + 36] = 1;  // reserved word of record 2
    expectRejected(path("record_reserved.bin"), bad, "record 2");
}

}  // namespace
