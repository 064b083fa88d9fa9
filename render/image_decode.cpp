// Decoding PNG and JPEG images (textures) with stb_image, restricted to those two formats and
// to psub/image.h's size limits; the one place stb_image's implementation is compiled.
#include "psub/image.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_FAILURE_USERMSG
#define STBI_MAX_DIMENSIONS 16384
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>

namespace psub {
namespace {

static_assert(STBI_MAX_DIMENSIONS == kMaxImageSide);

[[noreturn]] void failDecode(const std::string& name, const std::string& why) {
    throw std::runtime_error(name + ": cannot decode the image: " + why);
}

struct StbFree {
    void operator()(stbi_uc* pixels) const { stbi_image_free(pixels); }
};

}  // namespace

Image decodeImage(std::span<const std::uint8_t> bytes, const std::string& name) {
    if (bytes.empty()) failDecode(name, "the file is empty");
    if (bytes.size() > std::size_t(std::numeric_limits<int>::max())) failDecode(name, "more than 2 GiB of bytes");
    const int length = int(bytes.size());
    int width = 0, height = 0, channels = 0;
    if (!stbi_info_from_memory(bytes.data(), length, &width, &height, &channels))
        failDecode(name, std::string("not a PNG or JPEG image we can read (") + stbi_failure_reason() + ")");
    if (width <= 0 || height <= 0 || std::uint32_t(width) > kMaxImageSide || std::uint32_t(height) > kMaxImageSide ||
        std::uint64_t(width) * std::uint64_t(height) > kMaxImagePixels)
        failDecode(name, std::to_string(width) + "x" + std::to_string(height) + " pixels is beyond the limit (" +
                             std::to_string(kMaxImageSide) + " a side, " + std::to_string(kMaxImagePixels) +
                             " in all)");
    const std::unique_ptr<stbi_uc, StbFree> pixels(
        stbi_load_from_memory(bytes.data(), length, &width, &height, &channels, 4));
    if (!pixels) failDecode(name, stbi_failure_reason());
    Image image{std::uint32_t(width), std::uint32_t(height), {}};
    image.rgba.assign(pixels.get(), pixels.get() + 4 * std::size_t(width) * std::size_t(height));
    return image;
}

Image readImage(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open the image: " + std::strerror(errno));
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw std::runtime_error(path + ": cannot read the image: " + std::strerror(errno));
    return decodeImage({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()}, path);
}

}  // namespace psub
