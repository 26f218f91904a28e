// Reading and writing whole files: what every command's input and output goes through, so that
// a file that cannot be read says why, and no reader ever sees a half-written file.
#pragma once

#include <string>

namespace cb {

// Reads the whole file at `path` into `bytes`; false when it cannot be opened or read (a folder
// included), for the caller to report with unreadableReason.
bool tryReadWholeFile(const std::string& path, std::string& bytes);
// The whole file at `path`; throws std::runtime_error "cannot read WHAT PATH: reason" otherwise.
std::string readWholeFile(const std::string& path, const std::string& what);

// The data of gzip-compressed `bytes` (one or more members, RFC 1952); throws
// std::invalid_argument naming what is wrong ("not gzip data", "truncated", zlib's reason).
std::string gunzip(const std::string& bytes);

// Why `path` cannot be read, for a message: "no such file", "it is a folder, not a file", or the
// system's reason ("Permission denied").
std::string unreadableReason(const std::string& path);

// Write `bytes` to `path` atomically (temporary file in the same folder, then rename).
void writeFileAtomically(const std::string& path, const std::string& bytes);
// Throws std::runtime_error naming `what` and `path` unless a file can be created at `path`
// (its folder exists and is writable, and it is not a folder, and the path does not start with
// '-', the mark of an option that took a file name's place): checked before long work. Leaves
// nothing behind and never touches an existing file at `path`.
void requireWritable(const std::string& path, const std::string& what);
// Where to keep work when its own destination cannot be written: `name` in $TMPDIR (or /tmp),
// else in the current folder; the first folder where a file can be created. Throws if none.
std::string fallbackPath(const std::string& name);
// Temporary name next to `path` for writers that need a file name (OpenEXR, libpng).
std::string temporarySiblingPath(const std::string& path);
void commitTemporary(const std::string& temporary, const std::string& path);

} // namespace cb
