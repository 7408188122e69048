// `raypack-cli diff A.png B.png`: how two images differ, the check every fast path is held to.
#include "app/cli/commands.h"
#include "renderer/error.h"
#include "renderer/image.h"

#include <cmath>
#include <cstdio>
#include <memory>

namespace raypack::cli {

CommandRunner addDiffCommand(CLI::App& app) {
    struct Flags {
        std::string a, b, out;
        uint32_t threshold = 0;
    };
    auto flags = std::make_shared<Flags>();
    CLI::App* command =
        app.add_subcommand("diff",
                           "Compare two PNG images of the same size pixel by pixel. Prints the number and share (%) of "
                           "differing pixels, the largest difference of any channel (0..255) and the PSNR over R, G, B "
                           "(dB, peak 255; inf for identical images). A pixel differs when any channel differs by "
                           "more than --threshold. Exit code: 0 when no pixel differs, 1 when some do, 2 on error "
                           "(missing or unreadable file, different sizes, bad flag).");
    command->add_option("A", flags->a, "First PNG image")->required();
    command->add_option("B", flags->b, "Second PNG image")->required();
    command->add_option("--out", flags->out,
                        "Write the difference image (differing pixels red, the rest a dimmed grey "
                        "of A) to this file: PNG for .png, JPEG for .jpg or .jpeg; any other extension is "
                        "refused before the images are read");
    command->add_option("--threshold", flags->threshold, "Largest channel difference (0..255) still counted as equal")
        ->check(CLI::Range(0u, 255u))
        ->capture_default_str();
    return [flags] {
        if (!flags->out.empty()) checkImageOutputPath("--out", flags->out);
        const Image a = readPng(flags->a);
        const Image b = readPng(flags->b);
        const ImageDiff diff = diffImages(a, b, uint8_t(flags->threshold), flags->a, flags->b);
        if (!flags->out.empty())
            writeImage(flags->out, diff.difference.width, diff.difference.height, diff.difference.rgba);
        std::printf("image size         %ux%u\n", a.width, a.height);
        std::printf("differing pixels   %llu of %llu (%.4f %%), threshold %u\n",
                    (unsigned long long)diff.differingPixels, (unsigned long long)diff.pixels,
                    100.0 * diff.differingShare, flags->threshold);
        std::printf("max channel diff   %u (0..255)\n", diff.maxChannelDifference);
        if (std::isinf(diff.psnr))
            std::printf("PSNR               inf dB (identical)\n");
        else
            std::printf("PSNR               %.2f dB\n", diff.psnr);
        if (!flags->out.empty()) std::printf("difference image   %s\n", flags->out.c_str());
        return diff.differingPixels == 0 ? kExitOk : kExitDiffer;
    };
}

}  // namespace raypack::cli
