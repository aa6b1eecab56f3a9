/* vdb.cpp - the OpenVDB reader of picvr_io (picvr_io_load_vdb, picvr_io_is_vdb; see
 * picvr_io.h).  C++17; no exception leaves this file: every failure becomes a status and
 * a message that names the file.
 *
 * OpenVDB's reader was not written for hostile files: it allocates whatever sizes a file
 * states (strings, compressed chunks), loops over counts it never checks against the
 * stream's end, and copies a chunk before checking its size (a heap overflow).  The
 * contract of picvr_io.h is that no file crashes a reader, so before OpenVDB sees the
 * file, a scan of our own walks every byte OpenVDB will read for the chosen grid, in
 * the order it reads them, and refuses anything outside what its writer produces:
 *   - the header (magic, file format versions 222..224, grid offsets, uuid), the file
 *     metadata and all grid descriptors: sizes within the file, offsets increasing;
 *   - the chosen grid (and the grid it instances): compression flags, metadata (known
 *     fixed-size types must have their size; strings and unknown types are skipped), a
 *     registered linear transform, the tree (one buffer; root tiles and children aligned,
 *     children in increasing order; child and value masks disjoint; every compressed
 *     value block: its flags, its count from the masks, a chunk size that matches, a
 *     blosc header validated by blosc itself, a zip size within compressBound).
 * Then OpenVDB reads the grid with plain (not memory-mapped) file reads.  What this
 * cannot cover: a file that changes between our scan and OpenVDB's read, and the
 * decompressors themselves (zlib; blosc after blosc_cbuffer_validate), which are written
 * for untrusted input.
 *
 * Process-wide side effect: OpenVDB is initialized, and the "__delayedload" metadata
 * type is unregistered, so that OpenVDB reads that metadata as opaque bytes (its own
 * parser trusts counts in the file).  It only serves delayed loading of memory-mapped
 * files, which this reader does not use; a host reading such files itself loses only
 * that optimization. */
#include "picvr_io.h"
#include "io/internal.h"

#ifndef PICVR_IO_NO_VDB

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>

#include <blosc.h>
#include <zlib.h>

#include <openvdb/openvdb.h>
#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/File.h>
#include <openvdb/tree/LeafManager.h>

/* Largest densified volume accepted, in bytes (a fuzzing build lowers it). */
#ifndef PICVR_IO_VDB_MAX_BYTES
#define PICVR_IO_VDB_MAX_BYTES ((uint64_t)4 << 30)
#endif

namespace {

/* File format versions read: 222 (per-node mask compression) up to the newest OpenVDB 10
   writes.  Older formats use different node layouts that the scan does not walk. */
constexpr uint32_t MIN_FILE_VERSION = 222;
constexpr uint32_t MAX_FILE_VERSION = openvdb::OPENVDB_FILE_VERSION;
constexpr int NAME_QUOTE_MAX = 80;   /* characters of a grid name quoted in messages */

struct Failure {
    picvr_io_status status;
    std::string message;
};

[[noreturn]] void fail(picvr_io_status status, const std::string &message)
{
    throw Failure{status, message};
}

std::string quote(const std::string &s)
{
    std::string out = "'";
    for (size_t i = 0; i < s.size() && i < (size_t)NAME_QUOTE_MAX; i++) {
        unsigned char c = (unsigned char)s[i];
        if (c == 0x1e) out += '#';                 /* OpenVDB's unique-name separator */
        else out += (c >= 32 && c < 127) ? (char)c : '?';
    }
    if (s.size() > (size_t)NAME_QUOTE_MAX) out += "...";
    return out + "'";
}

/* ---- bounded reading of the file --------------------------------------------------- */

/* Reads the file within [pos, end): a read past `end` fails, as truncation when `end`
   is the end of the file, else as a region (a grid) that overruns its stated extent. */
class Reader {
public:
    Reader(FILE *f, uint64_t size, const std::string &path) : f_(f), size_(size), end_(size), path_(path) {}

    uint64_t pos() const { return pos_; }
    uint64_t remaining() const { return end_ - pos_; }
    void seek(uint64_t at, uint64_t end)
    {
        if (at > end || end > size_) fail(PICVR_IO_ERROR_BAD_HEADER, path_ + ": a grid extent outside the file");
        if (fseeko(f_, (off_t)at, SEEK_SET) != 0)
            fail(PICVR_IO_ERROR_READ, path_ + ": seek error: " + std::strerror(errno));
        pos_ = at;
        end_ = end;
    }
    void need(uint64_t n, const char *what)
    {
        if (n <= end_ - pos_) return;
        if (end_ == size_) fail(PICVR_IO_ERROR_TRUNCATED, path_ + ": truncated: the file ends inside " + what);
        fail(PICVR_IO_ERROR_BAD_HEADER, path_ + ": a grid's data ends (where its descriptor says) inside " + what);
    }
    void read(void *p, size_t n, const char *what)
    {
        need(n, what);
        if (n && fread(p, 1, n, f_) != n)
            fail(PICVR_IO_ERROR_READ, path_ + ": read error in " + what);
        pos_ += n;
    }
    void skip(uint64_t n, const char *what)
    {
        need(n, what);
        if (n && fseeko(f_, (off_t)(pos_ + n), SEEK_SET) != 0)
            fail(PICVR_IO_ERROR_READ, path_ + ": seek error: " + std::strerror(errno));
        pos_ += n;
    }
    template <typename T> T get(const char *what)
    {
        T v;
        read(&v, sizeof v, what);   /* OpenVDB uses its host's byte order: little-endian here */
        return v;
    }
    /* OpenVDB's string: a uint32 length, then the bytes. */
    std::string str(const char *what)
    {
        uint32_t n = get<uint32_t>(what);
        need(n, what);
        std::string s(n, '\0');
        read(&s[0], n, what);
        return s;
    }
    const std::string &path() const { return path_; }

private:
    FILE *f_;
    uint64_t pos_ = 0, size_, end_;
    std::string path_;
};

/* ---- header, file metadata, grid descriptors ---------------------------------------- */

const char SEP = '\x1e';   /* OpenVDB's separator of a unique grid name's "[N]" suffix */

struct Descriptor {
    std::string unique;   /* the unique name ("density", or "density" SEP "1") */
    std::string name;     /* the grid name: unique without its suffix */
    std::string type;     /* "Tree_float_5_4_3", without "_HalfFloat" */
    bool half = false;    /* values stored as 16-bit floats */
    std::string parent;   /* unique name of the grid whose tree this one shares, or "" */
    uint64_t grid_pos = 0, end_pos = 0;
};

std::string name_as_string(const std::string &unique)   /* io::GridDescriptor::nameAsString */
{
    size_t at = unique.find(SEP);
    return at == std::string::npos ? unique : unique.substr(0, at) + "[" + unique.substr(at + 1) + "]";
}

std::string string_as_unique_name(std::string s)   /* io::GridDescriptor::stringAsUniqueName */
{
    if (!s.empty() && s.back() == ']') {
        size_t at = s.find('[');
        if (at != std::string::npos) {
            s.pop_back();
            s.replace(at, 1, 1, SEP);
        }
    }
    return s;
}

/* The descriptor io::File::findDescriptor(name) picks (same rules), or -1. */
long find_descriptor(const std::vector<Descriptor> &grids, const std::string &name)
{
    const std::string unique = string_as_unique_name(name);
    std::vector<size_t> range;
    for (size_t i = 0; i < grids.size(); i++)
        if (grids[i].name == name) range.push_back(i);
    if (range.empty()) {
        const std::string stripped = unique.substr(0, unique.find(SEP));
        for (size_t i = 0; i < grids.size(); i++)
            if (grids[i].name == stripped) range.push_back(i);
    }
    if (range.empty()) return -1;
    if (name == unique) return (long)range[0];
    for (size_t i : range)
        if (grids[i].unique == unique || grids[i].unique == name) return (long)i;
    return -1;
}

/* Metadata types OpenVDB registers with a fixed size: it reads that many bytes whatever
   size the file states, so the file's size must agree. */
long fixed_metadata_size(const std::string &type)
{
    static const struct { const char *type; long size; } sizes[] = {
        {"bool", 1}, {"int32", 4}, {"int64", 8}, {"float", 4}, {"double", 8},
        {"vec2i", 8}, {"vec2s", 8}, {"vec2d", 16}, {"vec3i", 12}, {"vec3s", 12}, {"vec3d", 24},
        {"vec4i", 16}, {"vec4s", 16}, {"vec4d", 32}, {"mat4s", 64}, {"mat4d", 128},
        {"ptidx32", 4}, {"ptidx64", 8}, {"ptdataidx32", 4}, {"ptdataidx64", 8}};
    for (const auto &s : sizes)
        if (type == s.type) return s.size;
    return -1;
}

/* A MetaMap (openvdb::MetaMap::readMeta). */
void scan_metadata(Reader &r, const char *what)
{
    uint32_t count = r.get<uint32_t>(what);
    if (count > r.remaining() / 12) r.need(UINT64_MAX, what);   /* each entry takes >= 12 bytes */
    for (uint32_t i = 0; i < count; i++) {
        const std::string name = r.str(what);
        const std::string type = r.str(what);
        const uint32_t bytes = r.get<uint32_t>(what);
        const long fixed = fixed_metadata_size(type);
        if (fixed >= 0 && (long)bytes != fixed)
            fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": " + what + " " + quote(name) + " of type " + quote(type) +
                 " has " + std::to_string(bytes) + " bytes, not " + std::to_string(fixed));
        if (fixed < 0 && type != "string" && openvdb::Metadata::isRegisteredType(type))
            fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": " + what + " " + quote(name) + " has type " + quote(type) +
                 ", which this reader does not check");
        if (type == "bool") {   /* a bool holding another byte than 0 or 1 is undefined */
            if (r.get<uint8_t>(what) > 1)
                fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": " + what + " " + quote(name) + ": a bool that is neither 0 nor 1");
            continue;
        }
        r.skip(bytes, what);   /* fixed sizes checked; strings and unregistered types: the stated bytes */
    }
}

struct FileHeader {
    uint32_t version = 0;
    std::vector<Descriptor> grids;
};

FileHeader scan_header(Reader &r)
{
    FileHeader h;
    unsigned char magic[8];
    static const unsigned char want[8] = {0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0};   /* int64 0x56444220 */
    size_t have = (size_t)std::min<uint64_t>(8, r.remaining());
    r.read(magic, have, "the header");
    if (std::memcmp(magic, want, have) != 0)
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": not a VDB file (no OpenVDB magic number)");
    if (have < 8) r.need(8, "the header");
    h.version = r.get<uint32_t>("the header");
    if (h.version < MIN_FILE_VERSION || h.version > MAX_FILE_VERSION)
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": VDB file format version " + std::to_string(h.version) +
             " (versions " + std::to_string(MIN_FILE_VERSION) + ".." + std::to_string(MAX_FILE_VERSION) + " are read)");
    r.skip(8, "the header");   /* library major and minor version */
    if (r.get<uint8_t>("the header") == 0)
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": a VDB stream without grid offsets (written by io::Stream) is not read");
    char uuid[36];
    r.read(uuid, sizeof uuid, "the header");
    for (int i = 0; i < 36; i++) {
        bool dash = i == 8 || i == 13 || i == 18 || i == 23;
        if (dash ? uuid[i] != '-' : !std::isxdigit((unsigned char)uuid[i]))
            fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": malformed VDB header (file uuid)");
    }
    scan_metadata(r, "the file metadata");
    int32_t count = r.get<int32_t>("the grid count");
    if (count < 0) fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": negative grid count");
    for (int32_t i = 0; i < count; i++) {
        Descriptor d;
        d.unique = r.str("a grid descriptor");
        d.name = d.unique.substr(0, d.unique.find(SEP));
        d.type = r.str("a grid descriptor");
        static const std::string half = "_HalfFloat";
        if (d.type.size() >= half.size() && d.type.compare(d.type.size() - half.size(), half.size(), half) == 0) {
            d.half = true;
            d.type.erase(d.type.size() - half.size());   /* as GridDescriptor::read: the last one */
        }
        d.parent = r.str("a grid descriptor");
        if (!openvdb::GridBase::isRegistered(d.type))
            fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": grid " + quote(name_as_string(d.unique)) + " has type " +
                 quote(d.type) + ", unknown to OpenVDB");
        int64_t grid_pos = r.get<int64_t>("a grid descriptor");
        r.skip(8, "a grid descriptor");   /* the position of the tree's buffers (0 for an instance): unused */
        int64_t end_pos = r.get<int64_t>("a grid descriptor");
        /* OpenVDB's writer puts the grid right after its descriptor; the next descriptor
           starts at end_pos.  Increasing positions bound the number of descriptors. */
        if (grid_pos != (int64_t)r.pos() || end_pos < grid_pos)
            fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": grid " + quote(name_as_string(d.unique)) +
                 ": inconsistent offsets in its descriptor");
        r.need((uint64_t)(end_pos - grid_pos), "a grid");
        d.grid_pos = (uint64_t)grid_pos;
        d.end_pos = (uint64_t)end_pos;
        r.skip((uint64_t)(end_pos - grid_pos), "a grid");
        h.grids.push_back(d);
    }
    return h;
}

/* ---- one grid: metadata, transform, tree -------------------------------------------- */

struct Bits {   /* a node mask as the file stores it: little-endian 64-bit words */
    std::vector<uint64_t> w;
    explicit Bits(size_t n) : w(n / 64) {}
    void load(Reader &r, const char *what) { r.read(w.data(), w.size() * 8, what); }
    bool on(size_t i) const { return (w[i >> 6] >> (i & 63)) & 1u; }
    uint64_t count() const
    {
        uint64_t c = 0;
        for (uint64_t x : w) c += (uint64_t)__builtin_popcountll(x);
        return c;
    }
};

class TreeScan {
public:
    TreeScan(Reader &r, size_t value_size, bool half, uint32_t compression)
        : r_(r), value_size_(value_size), half_(half), compression_(compression) {}

    /* Tree::readTopology then Tree::readBuffers, for a Tree_<float|double>_5_4_3. */
    void scan()
    {
        if (r_.get<int32_t>("the tree") != 1)
            fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": a multi-buffer tree (not read)");
        r_.skip(value_size_, "the tree");   /* background */
        uint32_t tiles = r_.get<uint32_t>("the tree"), children = r_.get<uint32_t>("the tree");
        if (tiles == 0 && children == 0) return;   /* an empty tree: nothing follows */
        if (tiles > r_.remaining() / (13 + value_size_)) r_.need(UINT64_MAX, "the root tiles");
        for (uint32_t i = 0; i < tiles; i++) {
            int32_t c[3];
            r_.read(c, sizeof c, "a root tile");
            r_.skip(value_size_, "a root tile");
            uint8_t active = r_.get<uint8_t>("a root tile");
            if (!aligned(c) || active > 1)
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": a malformed root tile");
        }
        if (children > r_.remaining() / (12 + 8192)) r_.need(UINT64_MAX, "the root's children");
        int32_t prev[3] = {0, 0, 0};
        for (uint32_t i = 0; i < children; i++) {
            int32_t c[3];
            r_.read(c, sizeof c, "a root child");
            /* RootNode keeps children in a std::map ordered by coordinates and reads their
               buffers in that order: the file's order must be that order. */
            if (!aligned(c) || (i > 0 && !std::lexicographical_compare(prev, prev + 3, c, c + 3)))
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": root children out of order or misaligned");
            std::memcpy(prev, c, sizeof prev);
            internal(5);
        }
        for (uint16_t on : leaves_) {   /* LeafNode::readBuffers, depth first as above */
            r_.skip(64, "a leaf buffer");   /* the value mask again (OpenVDB seeks over it) */
            values(512, on, "a leaf buffer");
        }
    }

private:
    static bool aligned(const int32_t c[3]) { return !(c[0] & 4095) && !(c[1] & 4095) && !(c[2] & 4095); }

    /* InternalNode::readTopology (log2dim 5 holds 4-nodes, 4 holds leaves). */
    void internal(int log2dim)
    {
        const size_t n = (size_t)1 << (3 * log2dim);
        Bits child(n), value(n);
        child.load(r_, "a node's child mask");
        value.load(r_, "a node's value mask");
        for (size_t i = 0; i < child.w.size(); i++)
            if (child.w[i] & value.w[i])
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": a node both has a child and a value at one place");
        values(n, value.count(), "a node's values");
        for (size_t i = 0; i < n; i++) {
            if (!child.on(i)) continue;
            if (log2dim == 5) {
                internal(4);
            } else {
                Bits leaf(512);   /* LeafNode::readTopology: the value mask */
                leaf.load(r_, "a leaf's value mask");
                leaves_.push_back((uint16_t)leaf.count());
            }
        }
    }

    /* io::readCompressedValues for a node of n values, `on` of them active. */
    void values(uint64_t n, uint64_t on, const char *what)
    {
        uint8_t flags = r_.get<uint8_t>(what);
        if (flags > 6) fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": " + what + ": unknown compression flags");
        if (flags == 2 || flags == 4 || flags == 5) r_.skip(value_size_, what);   /* inactive value(s) */
        if (flags == 5) r_.skip(value_size_, what);
        if (flags == 3 || flags == 4 || flags == 5) r_.skip(n / 8, what);          /* selection mask */
        const uint64_t count = ((compression_ & openvdb::io::COMPRESS_ACTIVE_MASK) && flags != 6) ? on : n;
        if (half_ && count == 0) return;   /* HalfReader reads nothing for no values */
        chunk(count * (half_ ? 2 : value_size_), what);
    }

    /* io::readData: blosc, zip or raw bytes for `bytes` bytes of values. */
    void chunk(uint64_t bytes, const char *what)
    {
        const bool blosc = compression_ & openvdb::io::COMPRESS_BLOSC;
        if (!blosc && !(compression_ & openvdb::io::COMPRESS_ZIP)) {
            r_.skip(bytes, what);
            return;
        }
        int64_t stated = r_.get<int64_t>(what);
        if (stated <= 0) {   /* stored uncompressed: OpenVDB copies before it checks the size */
            if (stated == INT64_MIN || (uint64_t)-stated != bytes)
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": " + what + ": a block of the wrong size");
            r_.skip(bytes, what);
        } else if (blosc) {
            if ((uint64_t)stated > bytes + BLOSC_MAX_OVERHEAD)
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": " + what + ": a compressed block larger than its data");
            buffer_.resize((size_t)stated);
            r_.read(buffer_.data(), buffer_.size(), what);
            size_t decoded = 0;
            if (blosc_cbuffer_validate(buffer_.data(), buffer_.size(), &decoded) != 0 || decoded != bytes)
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": " + what + ": a malformed blosc block");
        } else {
            if ((uint64_t)stated > (uint64_t)compressBound((uLong)bytes))
                fail(PICVR_IO_ERROR_BAD_HEADER, r_.path() + ": " + what + ": a compressed block larger than its data");
            r_.skip((uint64_t)stated, what);   /* zlib's inflate checks its own input */
        }
    }

    Reader &r_;
    size_t value_size_;
    bool half_;
    uint32_t compression_;
    std::vector<uint16_t> leaves_;     /* active voxels of each leaf, in file order */
    std::vector<char> buffer_;
};

/* io::Archive::readGrid for grid d (File::readGrid also reads an instance's parent). */
void scan_grid(Reader &r, const FileHeader &h, const Descriptor &d, int depth)
{
    r.seek(d.grid_pos, d.end_pos);
    const uint32_t compression = r.get<uint32_t>("a grid");
    if (compression > 7) fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": unknown grid compression flags");
    scan_metadata(r, "grid metadata");
    const std::string map = r.str("a grid transform");
    if (!openvdb::math::MapRegistry::isRegistered(map))
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": grid " + quote(name_as_string(d.unique)) +
             ": unknown transform " + quote(map));
    openvdb::math::MapBase::Ptr m = openvdb::math::MapRegistry::createMap(map);
    if (!m->isLinear())
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": grid " + quote(name_as_string(d.unique)) + " has a " + map +
             " transform: only linear transforms (scale, rotation, translation, affine) are read");
    std::ostringstream serialized;   /* linear maps have a fixed serialized size */
    m->write(serialized);
    r.skip(serialized.str().size(), "a grid transform");
    if (d.parent.empty()) {
        const size_t value_size = d.type == openvdb::DoubleGrid::gridType() ? 8 : 4;
        TreeScan(r, value_size, d.half, compression).scan();
        return;
    }
    long p = find_descriptor(h.grids, name_as_string(d.parent));
    if (p < 0 || depth > 0 || h.grids[(size_t)p].type != d.type)
        fail(PICVR_IO_ERROR_BAD_HEADER, r.path() + ": grid " + quote(name_as_string(d.unique)) +
             " is an instance of a missing or different grid " + quote(name_as_string(d.parent)));
    if (h.grids[(size_t)p].parent.empty()) scan_grid(r, h, h.grids[(size_t)p], depth + 1);
}

/* ---- choosing the grid ---------------------------------------------------------------- */

bool is_scalar(const Descriptor &d)
{
    return d.type == openvdb::FloatGrid::gridType() || d.type == openvdb::DoubleGrid::gridType();
}

std::string grid_list(const FileHeader &h)
{
    std::string s;
    for (size_t i = 0; i < h.grids.size() && i < 16; i++) {
        if (i) s += ", ";
        s += quote(name_as_string(h.grids[i].unique)) + " (" + h.grids[i].type + ")";
    }
    if (h.grids.size() > 16) s += ", ...";
    return h.grids.empty() ? "none" : s;
}

size_t choose_grid(const FileHeader &h, const char *wanted, const std::string &path)
{
    long i = -1;
    if (wanted) {
        i = find_descriptor(h.grids, wanted);
        if (i < 0)
            fail(PICVR_IO_ERROR_BAD_HEADER, path + ": no grid " + quote(wanted) + "; the file has: " + grid_list(h));
        if (!is_scalar(h.grids[(size_t)i]))
            fail(PICVR_IO_ERROR_BAD_HEADER, path + ": grid " + quote(wanted) + " is " + h.grids[(size_t)i].type +
                 ", not a float or double grid");
        return (size_t)i;
    }
    for (size_t k = 0; k < h.grids.size() && i < 0; k++)   /* "density", if scalar */
        if (h.grids[k].name == "density" && is_scalar(h.grids[k])) i = (long)k;
    for (size_t k = 0; k < h.grids.size() && i < 0; k++)   /* else the first float grid */
        if (h.grids[k].type == openvdb::FloatGrid::gridType()) i = (long)k;
    for (size_t k = 0; k < h.grids.size() && i < 0; k++)   /* else the first double grid */
        if (h.grids[k].type == openvdb::DoubleGrid::gridType()) i = (long)k;
    if (i < 0) fail(PICVR_IO_ERROR_BAD_HEADER, path + ": no float or double grid; the file has: " + grid_list(h));
    return (size_t)i;
}

/* ---- densifying ------------------------------------------------------------------------ */

struct Dense {
    float *data = nullptr;
    int32_t min[3] = {0, 0, 0};
    uint64_t dims[3] = {0, 0, 0};
};

/* The active values of `tree` into d (which holds the background already). */
template <typename TreeT> void fill_active(const TreeT &tree, Dense &d)
{
    auto index = [&d](const openvdb::Coord &c) -> uint64_t {
        uint64_t x = (uint64_t)((int64_t)c[0] - d.min[0]), y = (uint64_t)((int64_t)c[1] - d.min[1]),
                 z = (uint64_t)((int64_t)c[2] - d.min[2]);
        if (x >= d.dims[0] || y >= d.dims[1] || z >= d.dims[2]) return UINT64_MAX;   /* never, by the bbox */
        return x + d.dims[0] * (y + d.dims[1] * z);
    };
    openvdb::tree::LeafManager<const TreeT> leaves(tree);
    leaves.foreach([&](const typename TreeT::LeafNodeType &leaf, size_t) {
        for (auto it = leaf.cbeginValueOn(); it; ++it) {
            uint64_t i = index(it.getCoord());
            if (i != UINT64_MAX) d.data[i] = (float)*it;
        }
    });
    /* Active tiles of the root and internal nodes (the leaves' voxels were done above). */
    typename TreeT::ValueOnCIter it = tree.cbeginValueOn();
    it.setMaxDepth(TreeT::RootNodeType::LEVEL - 1);
    for (; it; ++it) {
        if (it.isVoxelValue()) continue;
        openvdb::CoordBBox box;
        it.getBoundingBox(box);
        const float v = (float)*it;
        for (int64_t z = box.min()[2]; z <= box.max()[2]; z++)
            for (int64_t y = box.min()[1]; y <= box.max()[1]; y++) {
                uint64_t a = index(openvdb::Coord(box.min()[0], (int32_t)y, (int32_t)z));
                uint64_t b = index(openvdb::Coord(box.max()[0], (int32_t)y, (int32_t)z));
                if (a != UINT64_MAX && b != UINT64_MAX) std::fill(d.data + a, d.data + b + 1, v);
            }
    }
}

/* The grid over its active bounding box `box` into volume->data (float32). */
template <typename GridT>
void densify(const GridT &grid, const openvdb::CoordBBox &box, const std::string &path, picvr_io_volume *volume,
             std::string &warning)
{
    if (box.empty())
        fail(PICVR_IO_ERROR_BAD_DIMS, path + ": grid " + quote(grid.getName()) + " has no active voxels (an empty grid)");
    Dense d;
    uint64_t count = 1;
    for (int a = 0; a < 3; a++) {
        d.min[a] = box.min()[a];
        d.dims[a] = (uint64_t)((int64_t)box.max()[a] - (int64_t)box.min()[a] + 1);
        if (d.dims[a] < 1 || d.dims[a] > PICVR_IO_MAX_DIM)
            fail(PICVR_IO_ERROR_BAD_DIMS, path + ": the active voxels span " + std::to_string(d.dims[a]) +
                 " voxels along axis " + std::to_string(a) + "; at most " + std::to_string(PICVR_IO_MAX_DIM) + " are read");
        count *= d.dims[a];   /* <= 65535^3: no overflow in 64 bits */
    }
    const uint64_t bytes = count * sizeof(float);
    if (bytes > (uint64_t)PICVR_IO_VDB_MAX_BYTES || bytes > (uint64_t)SIZE_MAX)
        fail(PICVR_IO_ERROR_SIZE_OVERFLOW, path + ": the active voxels span " + std::to_string(d.dims[0]) + "x" +
             std::to_string(d.dims[1]) + "x" + std::to_string(d.dims[2]) + " voxels, " + std::to_string(bytes >> 20) +
             " MiB as float32; at most " + std::to_string((uint64_t)PICVR_IO_VDB_MAX_BYTES >> 20) + " MiB are read");
    d.data = (float *)std::malloc((size_t)bytes);
    if (!d.data) fail(PICVR_IO_ERROR_OUT_OF_MEMORY, path + ": out of memory for " + std::to_string(bytes) + " bytes");
    try {
        std::fill(d.data, d.data + count, (float)grid.background());
        fill_active(grid.tree(), d);
    } catch (...) {
        std::free(d.data);
        throw;
    }
    uint64_t bad = 0;   /* picvr refuses NaN and infinities (also doubles beyond float) */
    for (uint64_t i = 0; i < count; i++)
        if (!std::isfinite(d.data[i])) {
            d.data[i] = 0.0f;
            bad++;
        }
    if (bad) warning += std::to_string(bad) + " non-finite voxel values replaced by 0; ";
    for (int a = 0; a < 3; a++) volume->dims[a] = (uint32_t)d.dims[a];
    volume->type = PICVR_VOXEL_FLOAT32;
    volume->data = d.data;
    volume->size = (size_t)bytes;
}

/* spacing, direction, origin from the grid's linear transform.  OpenVDB's voxel (i,j,k)
   has its centre at index coordinates (i,j,k) (cell-centred: it spans i-0.5..i+0.5), so
   the world position of index bbox.min() is that of voxel (0,0,0)'s centre.  World space
   is the file's own frame, in its units: VDB has no patient frame, so no axis is flipped. */
void geometry(const openvdb::math::Transform &xf, const openvdb::Coord &min, const std::string &path,
              picvr_io_volume *v, std::string &warning)
{
    if (!xf.isLinear()) fail(PICVR_IO_ERROR_BAD_HEADER, path + ": only linear transforms are read");
    const openvdb::math::MapBase &map = *xf.baseMap();
    const openvdb::Vec3d o = xf.indexToWorld(min);
    double axis[3][3];
    for (int a = 0; a < 3; a++) {
        openvdb::Vec3d e(0.0, 0.0, 0.0);
        e[a] = 1.0;
        /* The linear part of the map: indexToWorld(min + e_a) - indexToWorld(min), without
           the cancellation of subtracting two far-away positions. */
        const openvdb::Vec3d d = map.applyJacobian(e);
        const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const float flen = (float)len;
        if (!(std::isfinite(flen) && flen > 0.0f))
            fail(PICVR_IO_ERROR_BAD_HEADER, path + ": a voxel axis of zero, non-finite or beyond-float length");
        v->spacing[a] = flen;
        for (int c = 0; c < 3; c++) {
            axis[a][c] = d[c] / len;
            v->direction[3 * a + c] = (float)axis[a][c];
        }
        v->origin[a] = (float)o[a];
        if (!std::isfinite(v->origin[a]))
            fail(PICVR_IO_ERROR_BAD_HEADER, path + ": the volume's origin is beyond float");
    }
    double shear = 0.0;
    for (int a = 0; a < 3; a++)
        for (int b = a + 1; b < 3; b++)
            shear = std::max(shear, std::fabs(axis[a][0] * axis[b][0] + axis[a][1] * axis[b][1] + axis[a][2] * axis[b][2]));
    if (shear > 1e-6) warning += "the voxel axes are not orthogonal (a sheared transform); ";
}

/* Every load, before its scan: the registry is locked inside OpenVDB, unregistering an
   absent type does nothing, and a host that re-initialized OpenVDB in between is covered. */
void initialize()
{
    openvdb::initialize();   /* idempotent and thread-safe */
    openvdb::Metadata::unregisterType(openvdb::io::DelayedLoadMetadata::staticTypeName());
}

template <typename GridT>
void load_grid(const typename GridT::Ptr &grid, const std::string &path, picvr_io_volume *volume, std::string &warning)
{
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    densify(*grid, box, path, volume, warning);
    geometry(grid->transform(), box.min(), path, volume, warning);
}

picvr_io_status load(const char *path_c, const char *wanted, picvr_io_volume *volume)
{
    const std::string path = path_c;
    FILE *f = std::fopen(path_c, "rb");
    if (!f) fail(PICVR_IO_ERROR_OPEN, path + ": " + std::strerror(errno));
    struct stat st;
    if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
        std::fclose(f);
        fail(PICVR_IO_ERROR_OPEN, path + ": not a regular file");
    }
    initialize();
    FileHeader h;
    Descriptor chosen;
    try {
        Reader r(f, (uint64_t)st.st_size, path);
        h = scan_header(r);
        chosen = h.grids[choose_grid(h, wanted, path)];
        scan_grid(r, h, chosen, 0);
    } catch (...) {
        std::fclose(f);
        throw;
    }
    std::fclose(f);

    /* The name OpenVDB resolves to the chosen grid (and to no other). */
    const std::string query = name_as_string(chosen.unique);
    const long again = find_descriptor(h.grids, query);
    if (again < 0 || h.grids[(size_t)again].grid_pos != chosen.grid_pos)
        fail(PICVR_IO_ERROR_BAD_HEADER, path + ": grid names that OpenVDB cannot tell apart: " + quote(query));

    openvdb::io::File file(path);
    file.open(/*delayLoad=*/false);   /* plain reads: no memory mapping, no temporary copy */
    openvdb::GridBase::Ptr base = file.readGrid(query);
    file.close();

    std::string warning;
    if (auto g = openvdb::gridPtrCast<openvdb::FloatGrid>(base)) {
        load_grid<openvdb::FloatGrid>(g, path, volume, warning);
    } else if (auto g2 = openvdb::gridPtrCast<openvdb::DoubleGrid>(base)) {
        warning += "float64 grid converted to float32; ";
        load_grid<openvdb::DoubleGrid>(g2, path, volume, warning);
    } else {
        fail(PICVR_IO_ERROR_BAD_HEADER, path + ": grid " + quote(query) + " is not a float grid");
    }
    volume->value_scale = 1.0;
    volume->value_offset = 0.0;
    volume->patient_frame = 0;   /* the file's own axes (see geometry) */
    volume->has_origin = 1;
    if (!warning.empty()) {
        warning.resize(warning.size() - 2);   /* the last "; " */
        std::snprintf(volume->warning, sizeof volume->warning, "%s", warning.c_str());
    }
    return PICVR_IO_OK;
}

} // namespace

extern "C" picvr_io_status picvr_io_load_vdb(const char *path, const char *grid, picvr_io_volume *volume,
                                             char *err, size_t err_size)
{
    if (volume) std::memset(volume, 0, sizeof *volume);
    if (!path || !volume) {
        picvr_io_set_error(err, err_size, "no file name or output given");
        return PICVR_IO_ERROR_NULL_POINTER;
    }
    picvr_io_status status;
    std::string message;
    try {
        return load(path, grid, volume);
    } catch (const Failure &e) {
        status = e.status;
        message = e.message;
    } catch (const std::bad_alloc &) {
        status = PICVR_IO_ERROR_OUT_OF_MEMORY;
        message = std::string(path) + ": out of memory";
    } catch (const openvdb::ArithmeticError &e) {   /* e.g. a singular affine transform */
        status = PICVR_IO_ERROR_BAD_HEADER;
        message = std::string(path) + ": OpenVDB: " + e.what();
    } catch (const std::exception &e) {
        status = PICVR_IO_ERROR_READ;   /* corrupt compressed data and the like */
        message = std::string(path) + ": OpenVDB: " + e.what();
    } catch (...) {
        status = PICVR_IO_ERROR_READ;
        message = std::string(path) + ": OpenVDB failed";
    }
    std::free(volume->data);
    std::memset(volume, 0, sizeof *volume);
    picvr_io_set_error(err, err_size, "%s", message.c_str());
    return status;
}

#else /* PICVR_IO_NO_VDB */

#include <cstring>

extern "C" picvr_io_status picvr_io_load_vdb(const char *path, const char *grid, picvr_io_volume *volume,
                                             char *err, size_t err_size)
{
    (void)grid;
    if (volume) std::memset(volume, 0, sizeof *volume);
    picvr_io_set_error(err, err_size, "%s: this build reads no OpenVDB files (built with PICVR_IO_NO_VDB)",
                       path ? path : "(null)");
    return PICVR_IO_ERROR_UNSUPPORTED;
}

#endif /* PICVR_IO_NO_VDB */

extern "C" int picvr_io_is_vdb(const char *path)
{
    return picvr_io_has_suffix(path, ".vdb");
}
