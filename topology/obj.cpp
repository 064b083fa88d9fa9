// OBJ reading (fast, line-accurate errors) and formatting (psub::output writes the text).
#include "psub/topology.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <new>
#include <set>
#include <string>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace psub {
namespace {

bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

std::string_view skipSpace(std::string_view s) {
    std::size_t i = 0;
    while (i < s.size() && isSpace(s[i])) ++i;
    return s.substr(i);
}

std::string_view nextToken(std::string_view& s) {
    s = skipSpace(s);
    std::size_t i = 0;
    while (i < s.size() && !isSpace(s[i])) ++i;
    std::string_view token = s.substr(0, i);
    s = s.substr(i);
    return token;
}

// A token as shown in a message: control bytes replaced, long tokens cut.
std::string shown(std::string_view token) {
    std::string out;
    for (char c : token.substr(0, 40)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    return token.size() > 40 ? out + "..." : out;
}

enum class NumberRead { Ok, NotANumber, OutOfRange };

// A decimal number as OBJ writes it ("+1" too). Magnitudes beyond double's range are
// OutOfRange; a magnitude below the smallest denormal (1e-400) underflows to a signed zero,
// denormals are kept: both are what the nearest double to the written number is.
NumberRead readNumber(std::string_view token, double& value) {
    if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
    const char* end = token.data() + token.size();
    const auto [stop, ec] = std::from_chars(token.data(), end, value);
    if (token.empty() || stop != end) return NumberRead::NotANumber;
    if (ec == std::errc()) return NumberRead::Ok;
    if (ec != std::errc::result_out_of_range) return NumberRead::NotANumber;
    const std::string copy(token);  // strtod tells overflow (HUGE_VAL) from underflow
    value = std::strtod(copy.c_str(), nullptr);
    return std::isinf(value) ? NumberRead::OutOfRange : NumberRead::Ok;
}

std::string at(const std::string& name, std::uint32_t line) {
    return name + ":" + std::to_string(line) + ": ";
}

// Parses one OBJ statement at a time; keeps the state that relative indices need.
class ObjParser {
public:
    ObjParser(const std::string& name, std::vector<std::string>* warnings)
        : name_(name), warnings_(warnings) {
        mesh_.source.path = name;
    }

    void statement(std::string_view line, std::uint32_t lineNo) {
        line = line.substr(0, line.find('#'));  // comments, also after a statement
        line = skipSpace(line);
        if (line.empty()) return;
        std::string_view keyword = nextToken(line);
        if (keyword == "v") return vertex(line, lineNo);
        if (keyword == "f") return face(line, lineNo);
        if (keyword == "vt") return textureCoordinate(line, lineNo);
        static const std::set<std::string_view> ignored = {"vn", "vp", "g", "o", "s",
                                                           "usemtl", "mtllib", "l"};
        if (ignored.count(keyword)) return;
        if (warnings_ && unknown_.insert(std::string(keyword)).second)
            warnings_->push_back(at(name_, lineNo) + "ignoring unknown statement '" +
                                 shown(keyword) + "'");
    }

    Mesh finish() {
        const Index vertexCount = Index(mesh_.positions.size() / 3);
        mesh_.faces.vertexCount = vertexCount;
        for (Index f = 0; f < mesh_.faces.faceCount(); ++f)
            for (Index v : mesh_.faces.face(f))
                if (v >= vertexCount)
                    throw InputError(describeFace(mesh_.source, f) + ": vertex index " +
                                     std::to_string(std::uint64_t(v) + 1) +
                                     " is out of range (the file has " +
                                     std::to_string(vertexCount) + " vertices)");
        finishUv();
        return std::move(mesh_);
    }

private:
    // A `v` statement: x y z, optionally w (x y z w) or a colour (x y z r g b [a]); nothing else.
    void vertex(std::string_view rest, std::uint32_t lineNo) {
        const std::size_t v = mesh_.positions.size() / 3;
        const std::string where = at(name_, lineNo) + "vertex " + std::to_string(v + 1) + ": ";
        double values[7] = {};
        std::size_t count = 0;
        for (std::string_view token = nextToken(rest); !token.empty(); token = nextToken(rest)) {
            if (count == 7)
                throw InputError(where + "unexpected '" + shown(token) +
                                 "' after 7 numbers (x y z, x y z w, x y z r g b or x y z r g b a)");
            const NumberRead read = readNumber(token, values[count]);
            if (read == NumberRead::OutOfRange)
                throw InputError(where + "number out of range: '" + shown(token) + "'");
            if (read == NumberRead::NotANumber)
                throw InputError(where + (count < 3 ? "expected 3 numbers, got '"
                                                    : "unexpected '") + shown(token) +
                                 (count < 3 ? "'" : "' after the coordinates"));
            ++count;
        }
        if (count < 3) throw InputError(where + "expected 3 numbers, got " + std::to_string(count));
        if (count == 5)
            throw InputError(where + "5 numbers: expected x y z, x y z w, x y z r g b or x y z r g b a");
        for (std::size_t axis = 0; axis < 3; ++axis) {
            if (!std::isfinite(values[axis]))
                throw InputError(where + "coordinate " + "xyz"[axis] + " is not finite");
            mesh_.positions.push_back(values[axis]);
        }
        mesh_.source.vertexLine.push_back(lineNo);
    }

    // A `vt` statement: u [v [w]]; u and v are kept (v defaults to 0), w is ignored.
    void textureCoordinate(std::string_view rest, std::uint32_t lineNo) {
        const std::size_t t = mesh_.uv.values.size() / 2;
        const std::string where = at(name_, lineNo) + "texture coordinate " + std::to_string(t + 1) + ": ";
        double values[3] = {};
        std::size_t count = 0;
        for (std::string_view token = nextToken(rest); !token.empty(); token = nextToken(rest)) {
            if (count == 3) throw InputError(where + "unexpected '" + shown(token) + "' after 3 numbers (u v w)");
            const NumberRead read = readNumber(token, values[count]);
            if (read == NumberRead::OutOfRange) throw InputError(where + "number out of range: '" + shown(token) + "'");
            if (read == NumberRead::NotANumber) throw InputError(where + "expected a number, got '" + shown(token) + "'");
            if (!std::isfinite(values[count])) throw InputError(where + "uvw"[count] + std::string(" is not finite"));
            ++count;
        }
        if (count == 0) throw InputError(where + "expected u [v [w]], got nothing");
        mesh_.uv.values.push_back(values[0]);
        mesh_.uv.values.push_back(values[1]);
        mesh_.uv.valueLine.push_back(lineNo);
    }

    // Checks the `vt` indices of faces that name them; drops the channel when some faces do not.
    void finishUv() {
        FaceVarying& uv = mesh_.uv;
        const Index count = uv.valueCount();
        if (anyUvNamed_ && count == 0) {  // no `vt` statement at all: nothing to refer to
            if (warnings_)
                warnings_->push_back(name_ + ": faces name texture coordinates but the file has no vt statement; ignoring them");
            uv.corners.clear();
        } else if (firstFaceWithoutUv_ != kNoIndex && anyUvNamed_) {
            if (warnings_)
                warnings_->push_back(describeFace(mesh_.source, firstFaceWithoutUv_) +
                                     " lacks a texture coordinate at some corner while others name one; ignoring all texture coordinates");
            uv.corners.clear();
        }
        for (Index f = 0; f < mesh_.faces.faceCount() && !uv.corners.empty(); ++f)
            for (Index h = mesh_.faces.offsets[f]; h < mesh_.faces.offsets[f + 1]; ++h)
                if (uv.corners[h] >= count)
                    throw InputError(describeFace(mesh_.source, f) + ": texture-coordinate index " +
                                     std::to_string(std::uint64_t(uv.corners[h]) + 1) +
                                     " is out of range (the file has " + std::to_string(count) +
                                     " texture coordinates)");
        if (uv.corners.empty()) {
            uv.values.clear();
            uv.valueLine.clear();
        }
        separateSharedValues(mesh_);
    }

    // The `vt` part of a face entry (after the first '/'), resolved, or kNoIndex when absent.
    Index uvReference(std::string_view rest, Index f, std::uint32_t lineNo) {
        if (rest.empty() || rest.front() == '/') return kNoIndex;  // "i" or "i//n"
        const std::string where = at(name_, lineNo) + "face " + std::to_string(std::uint64_t(f) + 1) + ": ";
        std::int64_t index = 0;
        auto [end, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), index);
        if (ec != std::errc() || (end != rest.data() + rest.size() && *end != '/'))
            throw InputError(where + "bad texture-coordinate reference '" + shown(rest) + "'");
        const std::int64_t seen = std::int64_t(mesh_.uv.values.size() / 2);
        if (index == 0) throw InputError(where + "texture-coordinate index 0 (OBJ indices start at 1)");
        if (index < 0 && seen + index < 0)
            throw InputError(where + "relative texture-coordinate index " + std::to_string(index) +
                             " points before the first texture coordinate (" + std::to_string(seen) + " so far)");
        const std::int64_t resolved = index < 0 ? seen + index : index - 1;
        if (resolved >= std::int64_t(kNoIndex))
            throw InputError(where + "texture-coordinate index " + shown(rest) + " is too large");
        return Index(resolved);
    }

    void face(std::string_view rest, std::uint32_t lineNo) {
        const std::int64_t seen = std::int64_t(mesh_.positions.size() / 3);
        const Index f = mesh_.faces.faceCount();
        corners_.clear();
        for (std::string_view token = nextToken(rest); !token.empty(); token = nextToken(rest)) {
            std::int64_t index = 0;
            auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), index);
            const bool tailOk = end == token.data() + token.size() || *end == '/';
            if (ec != std::errc() || !tailOk)
                throw InputError(at(name_, lineNo) + "face " + std::to_string(std::uint64_t(f) + 1) +
                                 ": bad vertex reference '" + shown(token) + "'");
            if (index == 0)
                throw InputError(at(name_, lineNo) + "face " + std::to_string(std::uint64_t(f) + 1) +
                                 ": vertex index 0 (OBJ indices start at 1)");
            if (index < 0 && seen + index < 0)
                throw InputError(at(name_, lineNo) + "face " + std::to_string(std::uint64_t(f) + 1) +
                                 ": relative index " + std::to_string(index) +
                                 " points before the first vertex (" + std::to_string(seen) +
                                 " vertices so far)");
            const std::int64_t resolved = index < 0 ? seen + index : index - 1;
            if (resolved >= std::int64_t(kNoIndex))
                throw InputError(at(name_, lineNo) + "face " + std::to_string(std::uint64_t(f) + 1) +
                                 ": vertex index " + shown(token) + " is too large");
            corners_.push_back(Index(resolved));
            const std::size_t slash = token.find('/');
            const Index uvIndex = slash == std::string_view::npos ? kNoIndex : uvReference(token.substr(slash + 1), f, lineNo);
            uvCorners_.push_back(uvIndex);
            anyUvNamed_ = anyUvNamed_ || uvIndex != kNoIndex;
        }
        mesh_.faces.addFace(corners_);
        // A face with a corner that names no texture coordinate is a face without them.
        const bool hasUv = std::find(uvCorners_.begin(), uvCorners_.end(), kNoIndex) == uvCorners_.end();
        if (!hasUv && firstFaceWithoutUv_ == kNoIndex) firstFaceWithoutUv_ = f;
        if (hasUv) mesh_.uv.corners.insert(mesh_.uv.corners.end(), uvCorners_.begin(), uvCorners_.end());
        uvCorners_.clear();
        mesh_.source.faceLine.push_back(lineNo);
    }

    const std::string& name_;
    std::vector<std::string>* warnings_;
    std::set<std::string> unknown_;
    std::vector<Index> corners_, uvCorners_;
    Index firstFaceWithoutUv_ = kNoIndex;
    bool anyUvNamed_ = false;
    Mesh mesh_;
};

}  // namespace

std::string describeFace(const Source& source, Index f) {
    const std::string name = "face " + std::to_string(std::uint64_t(f) + 1);
    if (f < source.faceLine.size()) return at(source.path, source.faceLine[f]) + name;
    return (source.path.empty() ? "" : source.path + ": ") + name;
}

std::string describeVertex(const Source& source, Index v) {
    const std::string name = "vertex " + std::to_string(std::uint64_t(v) + 1);
    if (v < source.vertexLine.size()) return at(source.path, source.vertexLine[v]) + name;
    return (source.path.empty() ? "" : source.path + ": ") + name;
}

Mesh parseObj(std::string_view text, const std::string& name, std::vector<std::string>* warnings) {
    ObjParser parser(name, warnings);
    std::string joined;  // a statement continued over several lines with a trailing '\'
    std::uint32_t lineNo = 0, joinedLine = 0;
    if (text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);  // UTF-8 byte-order mark
    while (!text.empty()) {
        // Lines end in \n, \r\n or a lone \r (old Mac files).
        const std::size_t eol = text.find_first_of("\r\n");
        std::string_view line = text.substr(0, eol);
        std::size_t skip = eol == std::string_view::npos ? text.size() : eol + 1;
        if (eol != std::string_view::npos && text[eol] == '\r' && eol + 1 < text.size() && text[eol + 1] == '\n') ++skip;
        text.remove_prefix(skip);
        ++lineNo;
        while (!line.empty() && isSpace(line.back())) line.remove_suffix(1);
        const bool continues = !line.empty() && line.back() == '\\';
        if (continues || !joined.empty()) {
            if (joined.empty()) joinedLine = lineNo;
            joined.append(line.substr(0, line.size() - (continues ? 1 : 0)));
            joined.push_back(' ');
            if (continues && !text.empty()) continue;
            parser.statement(joined, joinedLine);
            joined.clear();
            continue;
        }
        parser.statement(line, lineNo);
    }
    return parser.finish();
}

std::string readInputFile(const std::string& path) {
    // Opened without blocking, so that a FIFO cannot hold the open; refused unless regular.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) throw InputError(path + ": cannot open: " + std::strerror(errno));
    struct stat info {};
    if (::fstat(fd, &info) != 0 || !S_ISREG(info.st_mode)) {
        const mode_t mode = info.st_mode;
        ::close(fd);
        const char* kind = S_ISDIR(mode)    ? "a directory"
                           : S_ISFIFO(mode) ? "a named pipe (FIFO)"
                           : S_ISCHR(mode)  ? "a character device"
                           : S_ISBLK(mode)  ? "a block device"
                           : S_ISSOCK(mode) ? "a socket"
                                            : "not a regular file";
        throw InputError(path + ": is " + kind + ", not a regular file (psub reads input only from files)");
    }
    std::string text;
    char buffer[1 << 16];
    try {
        for (;;) {
            const ssize_t got = ::read(fd, buffer, sizeof buffer);
            if (got < 0 && errno == EINTR) continue;
            if (got < 0) {
                const int error = errno;
                ::close(fd);
                throw InputError(path + ": cannot read: " + std::strerror(error));
            }
            if (got == 0) break;
            text.append(buffer, std::size_t(got));
        }
    } catch (const std::bad_alloc&) {
        ::close(fd);
        throw InputError(path + ": the file does not fit in memory (" + std::to_string(text.size()) +
                         " bytes read)");
    }
    ::close(fd);
    return text;
}

Mesh readObj(const std::string& path, std::vector<std::string>* warnings) {
    return parseObj(readInputFile(path), path, warnings);
}

namespace {

// `# ` header lines, then one `v` line per 3 numbers of `positions`.
void appendHeaderAndVertices(std::string& out, std::string_view header, std::span<const double> positions) {
    while (!header.empty()) {
        const std::size_t eol = header.find('\n');
        out += "# ";
        out += header.substr(0, eol);
        out += '\n';
        header = eol == std::string_view::npos ? std::string_view() : header.substr(eol + 1);
    }
    char buf[64];
    for (std::size_t i = 0; i + 2 < positions.size(); i += 3) {
        out += 'v';
        for (int axis = 0; axis < 3; ++axis) {
            buf[0] = ' ';
            char* end = std::to_chars(buf + 1, buf + sizeof buf, positions[i + axis]).ptr;
            out.append(buf, end);
        }
        out += '\n';
    }
}

void appendIndex(std::string& out, std::uint32_t index) {
    char buf[16];
    char* end = std::to_chars(buf, buf + sizeof buf, std::uint64_t(index) + 1).ptr;
    out.append(buf, end);
}

}  // namespace

std::string formatObjWithUv(std::span<const double> positions, std::span<const double> values,
                            std::uint32_t width, std::span<const std::uint32_t> faceOffsets,
                            std::span<const std::uint32_t> faceVerts,
                            std::span<const std::uint32_t> faceValues, std::string_view header) {
    std::string out;
    out.reserve(positions.size() * 12 + values.size() * 12 + faceVerts.size() * 16 + header.size() + 64);
    appendHeaderAndVertices(out, header, positions);
    char buf[64];
    for (std::size_t i = 0; width > 0 && i + width <= values.size(); i += width) {
        out += "vt";
        for (std::uint32_t j = 0; j < 2; ++j) {
            buf[0] = ' ';
            char* end = std::to_chars(buf + 1, buf + sizeof buf, j < width ? values[i + j] : 0.0).ptr;
            out.append(buf, end);
        }
        out += '\n';
    }
    for (std::size_t f = 0; f + 1 < faceOffsets.size(); ++f) {
        out += 'f';
        for (std::uint32_t c = faceOffsets[f]; c < faceOffsets[f + 1]; ++c) {
            out += ' ';
            appendIndex(out, faceVerts[c]);
            out += '/';
            appendIndex(out, faceValues[c]);
        }
        out += '\n';
    }
    return out;
}

std::string formatObj(const Faces& faces, std::span<const double> positions,
                      std::string_view header) {
    std::string out;
    out.reserve(positions.size() * 12 + faces.verts.size() * 8 + header.size() + 64);
    appendHeaderAndVertices(out, header, positions);
    char buf[64];
    for (Index f = 0; f < faces.faceCount(); ++f) {
        out += 'f';
        for (Index v : faces.face(f)) {
            buf[0] = ' ';
            char* end = std::to_chars(buf + 1, buf + sizeof buf, std::uint64_t(v) + 1).ptr;
            out.append(buf, end);
        }
        out += '\n';
    }
    return out;
}

}  // namespace psub
