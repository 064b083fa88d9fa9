// Decoding PNG (libpng's simplified API) and JPEG (libjpeg-turbo) images, for textures, into
// RGBA within psub/image.h's size limits. Both libraries are checked against their headers'
// sizes before any pixel is decoded; every failure is a std::runtime_error naming the image.
#include "psub/image.h"

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <string>

#include <png.h>
// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

namespace psub {
namespace {

[[noreturn]] void failDecode(const std::string& name, const std::string& why) {
    throw std::runtime_error(name + ": cannot decode the image: " + why);
}

// Empty when width x height is within the limits, else why not.
std::string sizeProblem(std::uint64_t width, std::uint64_t height) {
    if (width > 0 && height > 0 && width <= kMaxImageSide && height <= kMaxImageSide &&
        width * height <= kMaxImagePixels)
        return {};
    return std::to_string(width) + "x" + std::to_string(height) + " pixels is beyond the limit (" +
           std::to_string(kMaxImageSide) + " a side, " + std::to_string(kMaxImagePixels) + " in all)";
}

bool isPng(std::span<const std::uint8_t> bytes) {
    return bytes.size() >= 8 && png_sig_cmp(bytes.data(), 0, 8) == 0;
}

bool isJpeg(std::span<const std::uint8_t> bytes) {
    return bytes.size() >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF;
}

Image decodePng(std::span<const std::uint8_t> bytes, const std::string& name) {
    png_image png{};
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
        failDecode(name, std::string("PNG: ") + png.message);
    if (const std::string problem = sizeProblem(png.width, png.height); !problem.empty()) {
        png_image_free(&png);
        failDecode(name, problem);
    }
    png.format = PNG_FORMAT_RGBA;
    Image image{png.width, png.height, std::vector<std::uint8_t>(4 * std::size_t(png.width) * png.height)};
    if (!png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr))
        failDecode(name, std::string("PNG: ") + png.message);  // finish_read frees png on failure
    return image;
}

// libjpeg reports errors by calling error_exit, which must not return: it jumps back to
// runJpeg's setjmp. Everything the jump crosses is C code of libjpeg, and everything runJpeg
// changes lives in the caller's JpegJob, so no C++ object is skipped or left indeterminate.
struct JpegErrors {
    jpeg_error_mgr manager;  // first: libjpeg's info->err points here, and so to the whole struct
    std::jmp_buf jump;
    char message[JMSG_LENGTH_MAX];
};

struct JpegJob {
    jpeg_decompress_struct info{};
    JpegErrors errors{};
    jpeg_progress_mgr progress{};
    Image image;
    std::string problem;  // a limit of ours that the file breaks
};

// Progressive JPEGs may carry any number of scans, each a full pass: a crafted file with
// thousands of them takes minutes. Real files have at most a few dozen.
constexpr int kMaxJpegScans = 256;

JpegErrors& errorsOf(j_common_ptr info) { return *reinterpret_cast<JpegErrors*>(info->err); }

void onJpegError(j_common_ptr info) {
    (*info->err->format_message)(info, errorsOf(info).message);
    std::longjmp(errorsOf(info).jump, 1);
}

// Warnings (level -1: corrupt or truncated data, which libjpeg would fill with grey) are errors
// here; trace messages (level >= 0) are ignored.
void onJpegMessage(j_common_ptr info, int level) {
    if (level < 0) onJpegError(info);
}

void onJpegProgress(j_common_ptr info) {
    const auto* decompress = reinterpret_cast<j_decompress_ptr>(info);
    if (decompress->input_scan_number > kMaxJpegScans) {
        std::snprintf(errorsOf(info).message, JMSG_LENGTH_MAX, "more than %d progressive scans", kMaxJpegScans);
        std::longjmp(errorsOf(info).jump, 1);
    }
}

// Decodes into job.image; false with job.message or job.problem set on failure. No automatic
// object of this function is changed after setjmp.
bool runJpeg(JpegJob& job) {
    if (setjmp(job.errors.jump)) return false;
    jpeg_read_header(&job.info, TRUE);
    job.problem = sizeProblem(job.info.image_width, job.info.image_height);
    if (!job.problem.empty()) return false;
    job.info.out_color_space = JCS_EXT_RGBA;  // libjpeg-turbo: grey and YCbCr to RGBA, alpha 255
    jpeg_start_decompress(&job.info);
    job.image = Image{job.info.output_width, job.info.output_height,
                      std::vector<std::uint8_t>(4 * std::size_t(job.info.output_width) * job.info.output_height)};
    while (job.info.output_scanline < job.info.output_height) {
        JSAMPROW row = job.image.rgba.data() + 4 * std::size_t(job.info.output_width) * job.info.output_scanline;
        jpeg_read_scanlines(&job.info, &row, 1);
    }
    jpeg_finish_decompress(&job.info);
    return true;
}

Image decodeJpeg(std::span<const std::uint8_t> bytes, const std::string& name) {
    if (bytes.size() > std::numeric_limits<unsigned long>::max()) failDecode(name, "too many bytes");
    JpegJob job;
    job.info.err = jpeg_std_error(&job.errors.manager);
    job.errors.manager.error_exit = onJpegError;
    job.errors.manager.emit_message = onJpegMessage;
    job.progress.progress_monitor = onJpegProgress;
    jpeg_create_decompress(&job.info);
    job.info.progress = &job.progress;
    jpeg_mem_src(&job.info, bytes.data(), static_cast<unsigned long>(bytes.size()));
    const bool decoded = runJpeg(job);
    jpeg_destroy_decompress(&job.info);
    if (!job.problem.empty()) failDecode(name, job.problem);
    if (!decoded) failDecode(name, std::string("JPEG: ") + job.errors.message);
    if (job.image.rgba.size() != 4 * std::size_t(job.image.width) * job.image.height)
        failDecode(name, "JPEG: the decoder returned a different size");
    return std::move(job.image);
}

}  // namespace

Image decodeImage(std::span<const std::uint8_t> bytes, const std::string& name) {
    if (bytes.empty()) failDecode(name, "the file is empty");
    if (isPng(bytes)) return decodePng(bytes, name);
    if (isJpeg(bytes)) return decodeJpeg(bytes, name);
    failDecode(name, "not a PNG or JPEG image (no PNG signature and no JPEG start-of-image marker)");
}

Image readImage(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open the image: " + std::strerror(errno));
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) throw std::runtime_error(path + ": cannot read the image: " + std::strerror(errno));
    return decodeImage({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()}, path);
}

}  // namespace psub
