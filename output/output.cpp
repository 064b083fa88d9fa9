// The output layer: atomic replacement of regular files, write-through for devices, pipes
// and standard output, refusal of what must not be replaced; every error checked.
#include "psub/output.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace psub {
namespace {

enum class Kind { Atomic, Through, Stdout };

struct Target {
    Kind kind = Kind::Atomic;
    std::string path;          // after following symbolic links
    bool exists = false;
    struct stat info {};
};

[[noreturn]] void fail(const std::string& path, const std::string& what, int error) {
    throw OutputError(path + ": cannot " + what + ": " + std::strerror(error));
}

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
    throw OutputError(path + ": cannot write: " + why);
}

std::string directoryOf(const std::string& path) {
    const std::size_t slash = path.rfind('/');
    return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

// Follows symbolic links (relative targets from the link's directory) to the name written.
std::string followLinks(const std::string& path) {
    std::string current = path;
    for (int hops = 0; hops < 40; ++hops) {
        struct stat info {};
        if (::lstat(current.c_str(), &info) != 0 || !S_ISLNK(info.st_mode)) return current;
        std::string link(std::size_t(info.st_size > 0 ? info.st_size : 4096) + 1, '\0');
        const ssize_t n = ::readlink(current.c_str(), link.data(), link.size());
        if (n < 0) fail(path, "follow the symbolic link", errno);
        link.resize(std::size_t(n));
        current = link.starts_with('/') ? link : directoryOf(current) + link;
    }
    fail(path, "follow the symbolic link", ELOOP);
}

Target classify(const std::string& path) {
    if (path.empty()) refuse("(empty name)", "no file name given");
    Target target;
    if (path == "-") {
        target.kind = Kind::Stdout;
        target.path = "standard output";
        return target;
    }
    // stat follows every link in the kernel (also /proc's and /dev/fd's, which name no file);
    // only a regular file or a new name needs the link's target spelled out here.
    target.path = path;
    if (::stat(path.c_str(), &target.info) != 0) {
        if (errno != ENOENT) fail(path, "write", errno);
        target.path = followLinks(path);  // a dangling link: create its target
        return target;
    }
    target.exists = true;
    const mode_t mode = target.info.st_mode;
    if (S_ISDIR(mode)) refuse(path, "it is a directory");
    if (S_ISBLK(mode)) refuse(path, "it is a block device (psub writes only files, character devices and pipes)");
    if (S_ISSOCK(mode)) refuse(path, "it is a socket");
    if (S_ISCHR(mode) || S_ISFIFO(mode)) {
        target.kind = Kind::Through;
        return target;
    }
    target.path = followLinks(path);
    if (target.info.st_nlink > 1) {
        refuse(path, "it has " + std::to_string(target.info.st_nlink) +
                         " hard links, and replacing it would split them (remove the other links or "
                         "write to another name)");
    }
    return target;
}

void writeAll(int fd, std::string_view bytes, const std::string& path) {
    for (std::size_t done = 0; done < bytes.size();) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) fail(path, "write", n < 0 ? errno : EIO);
        done += std::size_t(n);
    }
}

void writeThrough(const Target& target, const std::string& path, std::string_view bytes) {
    if (target.kind == Kind::Stdout) {
        finishStdout();
        writeAll(STDOUT_FILENO, bytes, target.path);
        return;
    }
    const int fd = ::open(target.path.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) fail(path, "open for writing", errno);
    try {
        writeAll(fd, bytes, path);
    } catch (...) {
        ::close(fd);
        throw;
    }
    if (::close(fd) != 0) fail(path, "write", errno);
}

// A temporary beside the target holding `bytes`, flushed and closed, with the mode the
// target will have. Its name is short, so a target name near the length limit still works.
std::string writeTemporary(const Target& target, const std::string& path, std::string_view bytes) {
    std::string temp = directoryOf(target.path) + ".psub-XXXXXX";
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) fail(path, "write", errno);
    auto failHere = [&](const char* what) {
        const int error = errno;
        ::close(fd);
        ::unlink(temp.c_str());
        fail(path, what, error);
    };
    try {
        writeAll(fd, bytes, path);
    } catch (...) {
        ::close(fd);
        ::unlink(temp.c_str());
        throw;
    }
    mode_t mode = 0;
    if (target.exists) {
        mode = target.info.st_mode & 07777;
        if (::geteuid() == 0 && ::fchown(fd, target.info.st_uid, target.info.st_gid) != 0) failHere("keep the owner");
    } else {
        const mode_t mask = ::umask(0);
        ::umask(mask);
        mode = 0666 & ~mask;
    }
    if (::fchmod(fd, mode) != 0) failHere("set the permissions");
    if (::fsync(fd) != 0) failHere("write");
    if (::close(fd) != 0) {
        const int error = errno;
        ::unlink(temp.c_str());
        fail(path, "write", error);
    }
    return temp;
}

void renameInto(const std::string& temp, const Target& target, const std::string& path) {
    if (std::rename(temp.c_str(), target.path.c_str()) != 0) {
        const int error = errno;
        ::unlink(temp.c_str());
        fail(path, "write", error);
    }
}

// A second name (a hard link) beside `target` for its current contents, so that writeOutputs
// can put them back; a copy where the file system has no hard links.
std::string keepOldContents(const Target& target, const std::string& path) {
    for (int attempt = 0; attempt < 100; ++attempt) {
        std::string keep = directoryOf(target.path) + ".psub-keep-XXXXXX";
        const int fd = ::mkstemp(keep.data());  // a free name, replaced by the link below
        if (fd < 0) fail(path, "keep the old contents", errno);
        ::close(fd);
        ::unlink(keep.c_str());
        if (::link(target.path.c_str(), keep.c_str()) == 0) return keep;
        if (errno == EEXIST) continue;
        if (errno != EPERM && errno != EOPNOTSUPP && errno != EXDEV && errno != EMLINK) fail(path, "keep the old contents", errno);
        std::FILE* in = std::fopen(target.path.c_str(), "rb");
        if (!in) fail(path, "keep the old contents", errno);
        std::string bytes;
        char buffer[1 << 16];
        for (std::size_t got; (got = std::fread(buffer, 1, sizeof buffer, in)) > 0;) bytes.append(buffer, got);
        const bool failed = std::ferror(in);
        std::fclose(in);
        if (failed) fail(path, "keep the old contents", EIO);
        return writeTemporary(target, path, bytes);
    }
    fail(path, "keep the old contents", EEXIST);
}

}  // namespace

void writeOutput(const std::string& path, std::string_view bytes) {
    const Target target = classify(path);
    if (target.kind != Kind::Atomic) return writeThrough(target, path, bytes);
    renameInto(writeTemporary(target, path, bytes), target, path);
}

void writeOutputs(const std::vector<OutputFile>& files) {
    std::vector<Target> targets;
    for (const OutputFile& file : files) targets.push_back(classify(file.first));
    std::vector<std::string> temps, keeps;  // keeps: a second link to each replaced file's old contents
    const auto removeAll = [](const std::vector<std::string>& names) {
        for (const std::string& name : names)
            if (!name.empty()) ::unlink(name.c_str());
    };
    try {
        for (std::size_t i = 0; i < files.size(); ++i) {
            const bool atomic = targets[i].kind == Kind::Atomic;
            temps.push_back(atomic ? writeTemporary(targets[i], files[i].first, files[i].second) : std::string());
            keeps.push_back(atomic && targets[i].exists ? keepOldContents(targets[i], files[i].first) : std::string());
        }
    } catch (...) {
        removeAll(temps);
        removeAll(keeps);
        throw;
    }
    for (std::size_t i = 0; i < files.size(); ++i) {
        if (temps[i].empty()) continue;
        try {
            renameInto(temps[i], targets[i], files[i].first);
        } catch (...) {
            // Put back what was already replaced: the old contents, or no file where there was none.
            for (std::size_t j = 0; j < i; ++j) {
                if (temps[j].empty()) continue;
                if (!keeps[j].empty()) {
                    std::rename(keeps[j].c_str(), targets[j].path.c_str());
                    keeps[j].clear();
                } else {
                    ::unlink(targets[j].path.c_str());
                }
            }
            for (std::size_t j = i + 1; j < files.size(); ++j)
                if (!temps[j].empty()) ::unlink(temps[j].c_str());
            removeAll(keeps);
            throw;
        }
    }
    removeAll(keeps);
    for (std::size_t i = 0; i < files.size(); ++i)
        if (temps[i].empty()) writeThrough(targets[i], files[i].first, files[i].second);
}

void checkOutput(const std::string& path) {
    const Target target = classify(path);
    if (target.kind == Kind::Stdout) return;
    if (target.kind == Kind::Through) {
        if (::access(target.path.c_str(), W_OK) != 0) fail(path, "open for writing", errno);
        return;
    }
    std::string temp = directoryOf(target.path) + ".psub-XXXXXX";
    const int fd = ::mkstemp(temp.data());
    if (fd < 0) fail(path, "write", errno);
    ::close(fd);
    ::unlink(temp.c_str());
}

void makeOutputDirectory(const std::string& path) {
    if (path.empty()) refuse("(empty name)", "no directory name given");
    std::error_code error;
    if (std::filesystem::exists(path, error) && !std::filesystem::is_directory(path, error))
        throw OutputError(path + ": cannot create the directory: it exists and is not a directory");
    std::filesystem::create_directories(path, error);
    if (error) throw OutputError(path + ": cannot create the directory: " + error.message());
    if (!std::filesystem::is_directory(path, error))
        throw OutputError(path + ": cannot create the directory: it exists and is not a directory");
}

void finishStdout() {
    errno = 0;
    const bool failed = std::fflush(stdout) != 0 || std::ferror(stdout);
    if (failed) fail("standard output", "write", errno ? errno : EIO);
}

}  // namespace psub
