// libFuzzer target: any bytes through the texture decoder (psub::decodeImage: libpng and
// libjpeg-turbo). Bad input must be a std::runtime_error, never a crash, a hang or a leak;
// a decoded image has exactly its RGBA pixels.
#include "psub/image.h"

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    try {
        const psub::Image image = psub::decodeImage({data, size}, "fuzz.png");
        if (image.rgba.size() != 4 * std::size_t(image.width) * image.height || image.width == 0) std::abort();
    } catch (const std::runtime_error&) {
    }
    return 0;
}
