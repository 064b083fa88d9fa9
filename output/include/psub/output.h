// psub/output.h: every file and stream psub writes goes through here. A regular file (or a
// name that does not exist yet) is replaced atomically; character devices, named pipes and
// standard output ("-") are written through; block devices, directories and hard-linked
// files are refused. Errors (a full disk, a closed pipe) are OutputError naming the path.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace psub {

// An output that could not be written; the message starts with the path (or "standard output").
class OutputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Writes `bytes` to `path`:
// - "-": standard output (after flushing stdio's buffer), written through.
// - a symbolic link: followed to its target (also a dangling one); the link stays a link.
// - a regular file with one link, or a name that does not exist: a temporary file in the same
//   directory is written, flushed to disk (fsync) and renamed over it, so on any failure the
//   old file is untouched and no temporary is left. An existing file keeps its permission
//   bits (and, for root, its owner); a new one gets 0666 less the umask.
// - a character device or a named pipe (e.g. /dev/null, /dev/stdout, a FIFO): opened for
//   writing and written through, never replaced.
// - a directory, a block device, a socket, or a regular file with more than one hard link
//   (replacing it would silently split the links): refused.
// Every write, fsync and close is checked; failures throw OutputError.
void writeOutput(const std::string& path, std::string_view bytes);

// One file's path and its bytes, for writeOutputs.
using OutputFile = std::pair<std::string, std::string>;

// Writes several files as one: every atomic target's temporary is written and flushed first,
// and a second link (or a copy) keeps each replaced file's old contents; only when all are
// complete are the temporaries renamed into place (written-through targets last). A failure
// while writing leaves none of the files changed; a failure renaming one puts back the files
// already replaced (their old contents, or no file where there was none). What POSIX leaves
// open: the renames are not one step, so a crash or kill between them leaves the earlier files
// replaced and a hidden ".psub-keep-*" file holding an old version beside each; and while they
// run, another reader can see the new first file beside the old second one.
void writeOutputs(const std::vector<OutputFile>& files);

// Throws the OutputError that writeOutput(path, ...) would throw for the kind of target or an
// unwritable directory, without writing anything: for commands that run long before writing.
void checkOutput(const std::string& path);

// Creates directory `path` and its missing parents (like mkdir -p); an existing directory is
// fine. Throws OutputError naming `path` and the reason (e.g. a component is a regular file).
void makeOutputDirectory(const std::string& path);

// Flushes standard output; throws OutputError when this or any earlier write to it failed
// (e.g. stdout on a full disk or a closed pipe). Commands call it before exiting with 0.
void finishStdout();

}  // namespace psub
