#include "io/files.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <stdexcept>
#include <unistd.h>
#include <vector>
#include <zlib.h>

namespace cb {

bool tryReadWholeFile(const std::string& path, std::string& bytes) {
    // A folder opens as a stream on Linux and fails only when read, with an exception.
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) return false;
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    try {
        bytes.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    } catch (const std::ios_base::failure&) {
        return false;
    }
    return !f.bad();
}

std::string gunzip(const std::string& bytes) {
    if (bytes.size() < 2 || bytes[0] != '\x1f' || bytes[1] != '\x8b')
        throw std::invalid_argument("not gzip data (no gzip header)");
    if (bytes.size() > std::numeric_limits<uInt>::max())
        throw std::invalid_argument("larger than zlib reads in one piece (4 GiB)");
    z_stream zs{};
    // 16 + MAX_WBITS: gzip framing only.
    if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK)
        throw std::runtime_error("zlib could not start decompressing");
    std::string out;
    std::vector<char> chunk(1 << 16);
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
    zs.avail_in = static_cast<uInt>(bytes.size());
    int status = Z_OK;
    for (;;) {
        zs.next_out = reinterpret_cast<Bytef*>(chunk.data());
        zs.avail_out = static_cast<uInt>(chunk.size());
        status = inflate(&zs, Z_NO_FLUSH);
        out.append(chunk.data(), chunk.size() - zs.avail_out);
        if (status == Z_STREAM_END) {
            if (zs.avail_in == 0) break;
            inflateReset(&zs); // the next of concatenated members, as gzip -d reads them
            continue;
        }
        if (status == Z_OK) continue;
        const std::string why = status == Z_BUF_ERROR ? "truncated (it ends inside a member)"
                                : zs.msg              ? std::string(zs.msg)
                                                      : "zlib error " + std::to_string(status);
        const auto at = zs.total_in;
        inflateEnd(&zs);
        throw std::invalid_argument(fmt::format("{} at compressed byte {}", why, at));
    }
    inflateEnd(&zs);
    return out;
}

std::string unreadableReason(const std::string& path) {
    std::error_code ec;
    const auto status = std::filesystem::status(path, ec);
    // A folder on the way that may not be searched fails here, not as "no such file".
    if (ec && ec != std::errc::no_such_file_or_directory && ec != std::errc::not_a_directory)
        return ec.message();
    if (!std::filesystem::exists(status)) return "no such file";
    if (std::filesystem::is_directory(status)) return "it is a folder, not a file";
    errno = 0; // so that a failed open below reports its own cause, not an earlier one
    std::ifstream probe(path, std::ios::binary);
    if (!probe) return errno != 0 ? std::string(std::strerror(errno)) : "it cannot be opened";
    return "reading it failed";
}

std::string readWholeFile(const std::string& path, const std::string& what) {
    std::string bytes;
    if (!tryReadWholeFile(path, bytes))
        throw std::runtime_error(
            fmt::format("cannot read {} {}: {}", what, path, unreadableReason(path)));
    return bytes;
}

std::string temporarySiblingPath(const std::string& path) {
    std::filesystem::path p(path);
    // Appended piece by piece: GCC 12 warns falsely (-Wrestrict, its bug 105651) on
    // "." + std::string&&.
    std::string name = ".";
    name += p.filename().string();
    name += ".tmp.";
    name += std::to_string(::getpid());
    return (p.parent_path() / name).string();
}

void commitTemporary(const std::string& temporary, const std::string& path) {
    std::error_code ec;
    std::filesystem::rename(temporary, path, ec);
    if (ec) {
        std::filesystem::remove(temporary);
        throw std::runtime_error("cannot write " + path + ": " + ec.message());
    }
}

void requireWritable(const std::string& path, const std::string& what) {
    namespace fs = std::filesystem;
    // `--stats -q` gives --stats the path "-q": an option that took a file name's place.
    if (!path.empty() && path[0] == '-')
        throw std::runtime_error(fmt::format(
            "cannot write {} {}: a path that starts with '-' is probably an option that took the "
            "file name's place; write ./{} for a file of that name",
            what, path, path));
    const fs::path p(path);
    std::error_code ec;
    if (fs::is_directory(p, ec))
        throw std::runtime_error(fmt::format("cannot write {} {}: it is a folder", what, path));
    const fs::path folder = p.parent_path().empty() ? fs::path(".") : p.parent_path();
    if (!fs::is_directory(folder, ec))
        throw std::runtime_error(fmt::format("cannot write {} {}: the folder {} does not exist",
                                             what, path, folder.string()));
    const std::string probe = temporarySiblingPath(path) + ".probe";
    std::FILE* f = std::fopen(probe.c_str(), "wb");
    if (!f)
        throw std::runtime_error(fmt::format("cannot write {} {}: cannot create files in {} ({})",
                                             what, path, folder.string(), std::strerror(errno)));
    std::fclose(f);
    fs::remove(probe, ec);
}

std::string fallbackPath(const std::string& name) {
    std::vector<std::string> folders;
    if (const char* tmp = std::getenv("TMPDIR"); tmp && *tmp) folders.push_back(tmp);
    folders.push_back("/tmp");
    folders.push_back(".");
    for (const auto& folder : folders) {
        const std::string path = (std::filesystem::path(folder) / name).string();
        try {
            requireWritable(path, "fallback");
            return path;
        } catch (const std::exception&) {
        }
    }
    throw std::runtime_error("no folder to keep the work in: $TMPDIR, /tmp and the current "
                             "folder are not writable");
}

namespace {

// fsync, where the file system has it (some answer EINVAL or ENOTSUP: nothing to wait for).
bool syncToDisk(std::FILE* f) {
    if (::fsync(::fileno(f)) == 0) return true;
    if (errno == EINVAL || errno == ENOTSUP || errno == ENOSYS) {
        errno = 0;
        return true;
    }
    return false;
}

} // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes) {
    const std::string tmp = temporarySiblingPath(path);
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f)
        throw std::runtime_error(
            fmt::format("cannot write {}: cannot create {} ({})", path, tmp, std::strerror(errno)));
    // A full disk may fail only when the buffer is flushed or the file closed, so every step is
    // checked (a failure at close had renamed an empty file into place), and the data reaches
    // the disk before the rename makes it the file (a power cut must not leave an empty one).
    errno = 0;
    bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    ok = ok && std::fflush(f) == 0 && syncToDisk(f);
    const int error = errno;
    ok = std::fclose(f) == 0 && ok;
    if (!ok) {
        const std::string reason = std::strerror(error != 0 ? error : errno);
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        throw std::runtime_error(fmt::format("cannot write {}: {}", path, reason));
    }
    commitTemporary(tmp, path);
}

} // namespace cb
