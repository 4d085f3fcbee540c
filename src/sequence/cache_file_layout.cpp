// The OpenVDB part of a cache file as OpenVDB 10 writes dofcache's point grid (file format 224;
// values little-endian, as OpenVDB writes them on the machines dofcache builds for):
//
//   header        i64 magic, u32 format version, u32 u32 library version, u8 "has grid offsets",
//                 36 characters of UUID
//   file metadata u32 count, then per item: string name, string type, u32 size, value
//   descriptors   i32 grid count, then per grid: string name, string tree type, string instance
//                 parent, i64 grid position, i64 buffers position, i64 end position
//   grid          u32 compression, grid metadata (as above), transform (string map type, map),
//                 topology (i32 buffer count, root: background, u32 tiles, u32 children, then
//                 internal nodes 5 and 4 down to leaves: masks and compressed values),
//                 buffers (u16 passes; pass 0 a u16 per leaf; pass 1 the attribute descriptor and
//                 each leaf's attribute metadata; then the attribute and voxel data)
//
// Strings are a u32 length and the bytes. Compressed blocks (blosc or zip) are an i64 size and
// the bytes, a negative size meaning that many uncompressed bytes.
#include "cache_file_layout.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "dofcache/core/error.h"

namespace dofcache::sequence {
namespace {

constexpr std::int64_t kVdbMagic = 0x56444220;
constexpr std::uint32_t kFileVersion = 224;  // OpenVDB 10's: multi-pass I/O
constexpr std::uint32_t kCompressActiveMask = 0x2, kCompressBlosc = 0x4;
constexpr const char* kTreeType = "Tree_ptdataidx32_5_4_3";  // points::PointDataTree
constexpr int kAttributes = 10;

// The metadata items write_cache_file and OpenVDB's writer put in a cache file, by type. Values
// of fixed-size types must have their size; strings any size the file has room for.
const std::map<std::string, std::string>& file_metadata_types() {
  static const std::map<std::string, std::string> types = {
      {"dofcache.format", "string"},       {"dofcache.version", "int32"},
      {"dofcache.scene_hash", "string"},   {"dofcache.scene", "string"},
      {"dofcache.light_samples", "int32"}, {"dofcache.gather_rays", "int32"},
      {"dofcache.bounces", "int32"},       {"dofcache.sample_quality", "int32"},
      {"dofcache.min_factor", "double"},   {"dofcache.sample_count", "int64"},
      {"dofcache.sequence_key", "string"}, {"dofcache.first_frame", "int32"},
      {"dofcache.frame", "int32"},         {"dofcache.environment_hash", "string"},
      {"dofcache.lens_design", "string"},  {"dofcache.lens", "string"}};
  return types;
}

const std::map<std::string, std::string>& grid_metadata_types() {
  static const std::map<std::string, std::string> types = {
      {"file_bbox_min", "vec3i"},  {"file_bbox_max", "vec3i"},     {"file_compression", "string"},
      {"file_mem_bytes", "int64"}, {"file_voxel_count", "int64"}, {"name", "string"}};
  return types;
}

// dofcache's attributes (cache_file.cpp's write_vdb): value type, all with the null codec.
const std::map<std::string, std::string>& attribute_types() {
  static const std::map<std::string, std::string> types = {
      {"P", "vec3s"},           {"N", "vec3s"},         {"value", "vec3s"},
      {"radius", "float"},      {"base_radius", "float"}, {"view_radius", "float"},
      {"footprint", "float"},   {"id", "int32"},        {"frame", "int32"},
      {"last_used", "int32"}};
  return types;
}

std::uint64_t fixed_size(const std::string& type) {
  if (type == "int32") return 4;
  if (type == "int64" || type == "double") return 8;
  if (type == "vec3i") return 12;
  return 0;  // strings
}

// A name from the file, fit for a one-line message.
std::string printable(const std::string& s) {
  std::string out;
  for (char c : s.substr(0, 64)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
  return s.size() > 64 ? out + "..." : out;
}

class LayoutWalker {
 public:
  LayoutWalker(const std::string& path, std::string_view data) : path_(path), data_(data) {}

  void walk() {
    header();
    const std::int64_t samples = file_metadata();
    const Descriptor grid = grid_descriptor();
    grid_header();
    const std::uint64_t leaves = topology();
    if (pos_ != grid.buffers)
      damaged("the grid's topology ends at byte " + std::to_string(pos_) +
              ", its descriptor says " + std::to_string(grid.buffers));
    buffers_metadata(leaves, samples);
    if (leaves > 0) buffers_data();
    if (pos_ != grid.end)
      damaged("the grid's data ends at byte " + std::to_string(pos_) + ", its descriptor says " +
              std::to_string(grid.end));
  }

 private:
  struct Descriptor {
    std::uint64_t grid = 0, buffers = 0, end = 0;
  };

  [[noreturn]] void damaged(const std::string& what) const {
    throw Error(path_ + ": cache file is damaged (" + what + ")");
  }
  [[noreturn]] void not_ours(const std::string& what) const {
    throw Error(path_ + ": not a dofcache cache file (" + what + ")");
  }

  std::uint64_t remaining() const { return data_.size() - pos_; }
  void need(std::uint64_t n, const std::string& what) const {
    if (n > remaining())
      damaged(what + " needs " + std::to_string(n) + " bytes, " + std::to_string(remaining()) +
              " remain");
  }
  void skip(std::uint64_t n, const std::string& what) {
    need(n, what);
    pos_ += n;
  }
  template <class T>
  T read(const std::string& what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string string(const std::string& what) {
    const auto n = read<std::uint32_t>(what);
    need(n, what);
    std::string s(data_.substr(pos_, n));
    pos_ += n;
    return s;
  }

  void header() {
    if (read<std::int64_t>("the OpenVDB header") != kVdbMagic)
      not_ours("no OpenVDB magic number");
    const auto version = read<std::uint32_t>("the OpenVDB header");
    if (version != kFileVersion)
      not_ours("OpenVDB file format " + std::to_string(version) + ", dofcache writes " +
               std::to_string(kFileVersion));
    skip(8, "the OpenVDB header");  // library version, major and minor
    if (read<std::uint8_t>("the OpenVDB header") != 1) damaged("no grid offsets");
    need(36, "the file's UUID");
    for (int i = 0; i < 36; ++i) {
      const char c = data_[pos_ + i];
      const bool dash = i == 8 || i == 13 || i == 18 || i == 23;
      if (dash ? c != '-' : !std::isxdigit(static_cast<unsigned char>(c))) damaged("bad UUID");
    }
    pos_ += 36;
  }

  // A metadata map whose items must all be among `types`, each at most once. Returns the value
  // of the int64 item `int64_key` (or -1 if absent).
  std::int64_t metadata(const std::map<std::string, std::string>& types, const std::string& of,
                        const std::string& int64_key = "") {
    const auto count = read<std::uint32_t>(of + " metadata count");
    if (count > types.size())
      damaged(of + " metadata of " + std::to_string(count) + " items, at most " +
              std::to_string(types.size()) + " expected");
    std::set<std::string> seen;
    std::int64_t int64_value = -1;
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::string name = string(of + " metadata name");
      const std::string type = string(of + " metadata '" + printable(name) + "' type");
      auto expected = types.find(name);
      if (expected == types.end())
        not_ours("unexpected " + of + " metadata '" + printable(name) + "'");
      if (type != expected->second)
        not_ours(of + " metadata '" + name + "' is of type '" + printable(type) + "', not " +
                 expected->second);
      if (!seen.insert(name).second) damaged(of + " metadata '" + name + "' twice");
      const auto size = read<std::uint32_t>(of + " metadata '" + name + "' size");
      const std::uint64_t fixed = fixed_size(type);
      if (fixed != 0 && size != fixed)
        damaged(of + " metadata '" + name + "' of " + std::to_string(size) + " bytes, not " +
                std::to_string(fixed));
      need(size, of + " metadata '" + name + "'");
      if (name == int64_key) std::memcpy(&int64_value, data_.data() + pos_, 8);
      pos_ += size;
    }
    return int64_value;
  }

  std::int64_t file_metadata() {
    const std::int64_t samples = metadata(file_metadata_types(), "file", "dofcache.sample_count");
    if (samples < 0) not_ours("no valid dofcache.sample_count metadata");
    return samples;
  }

  Descriptor grid_descriptor() {
    const auto grids = read<std::int32_t>("grid count");
    if (grids != 1) damaged(std::to_string(grids) + " grids, expected one");
    const std::string name = string("grid name");
    if (name != "samples") not_ours("a grid named '" + printable(name) + "', not 'samples'");
    const std::string type = string("grid type");
    if (type != kTreeType) not_ours("a grid of type '" + printable(type) + "', not point data");
    if (!string("grid instance parent").empty()) damaged("an instanced grid");
    Descriptor d;
    d.grid = read<std::uint64_t>("grid descriptor");
    d.buffers = read<std::uint64_t>("grid descriptor");
    d.end = read<std::uint64_t>("grid descriptor");
    if (d.grid != pos_ || !(d.grid < d.buffers && d.buffers < d.end) || d.end != data_.size())
      damaged("grid positions " + std::to_string(d.grid) + ", " + std::to_string(d.buffers) +
              ", " + std::to_string(d.end) + " in a file of " + std::to_string(data_.size()) +
              " bytes");
    return d;
  }

  void grid_header() {
    // write_cache_file asks for zip only where OpenVDB lacks blosc; then the attribute arrays are
    // not written in pages, a layout this walk does not know, so such files are refused.
    compression_ = read<std::uint32_t>("grid compression");
    if (compression_ != (kCompressBlosc | kCompressActiveMask))
      damaged("grid compression flags " + std::to_string(compression_));
    metadata(grid_metadata_types(), "grid");
    const std::string map = string("grid transform");
    if (map != "UniformScaleMap") not_ours("a grid transform '" + printable(map) + "'");
    skip(5 * 3 * 8, "grid transform");  // five Vec3d: scale, voxel size and their inverses
  }

  // The tree's nodes: a root with tiles and children of 32^3 internal nodes, whose children are
  // 16^3 internal nodes, whose children are 8^3 leaves. Returns the number of leaves.
  std::uint64_t topology() {
    if (read<std::int32_t>("tree topology") != 1) damaged("tree buffer count");
    skip(4, "tree background");
    const auto tiles = read<std::uint32_t>("root tile count");
    const auto children = read<std::uint32_t>("root child count");
    skip(std::uint64_t{tiles} * 17, "root tiles");  // origin, value, active flag
    std::uint64_t leaves = 0;
    for (std::uint32_t i = 0; i < children; ++i) {
      skip(12, "root child origin");
      internal_node(5, leaves);
    }
    return leaves;
  }

  // An internal node of 2^(3*log2dim) values: child mask, value mask, the values, the children.
  void internal_node(int log2dim, std::uint64_t& leaves) {
    const std::uint64_t mask_bytes = (std::uint64_t{1} << (3 * log2dim)) / 8;
    need(2 * mask_bytes, "internal node masks");
    const char* child_mask = data_.data() + pos_;
    const std::uint64_t active = count_bits(data_.data() + pos_ + mask_bytes, mask_bytes);
    pos_ += 2 * mask_bytes;
    compressed_values(mask_bytes * 8, active, mask_bytes);
    for (std::uint64_t word = 0; word < mask_bytes / 8; ++word) {
      std::uint64_t bits;
      std::memcpy(&bits, child_mask + 8 * word, 8);
      for (; bits != 0; bits &= bits - 1) {
        if (log2dim == 5) {
          internal_node(4, leaves);
        } else {
          skip(64, "leaf value mask");  // 8^3 bits
          ++leaves;
        }
      }
    }
  }

  static std::uint64_t count_bits(const char* p, std::uint64_t bytes) {
    std::uint64_t n = 0;
    for (std::uint64_t i = 0; i < bytes; i += 8) {
      std::uint64_t w;
      std::memcpy(&w, p + i, 8);
      n += static_cast<std::uint64_t>(__builtin_popcountll(w));
    }
    return n;
  }

  // An internal node's values (io::readCompressedValues): a flag saying what follows, up to two
  // inactive values, a selection mask, then the values (all, or only the active ones) as a block.
  void compressed_values(std::uint64_t values, std::uint64_t active, std::uint64_t mask_bytes) {
    const auto flag = read<std::int8_t>("node values");
    if (flag < 0 || flag > 6) damaged("node value flag " + std::to_string(flag));
    if (flag == 2 || flag == 4 || flag == 5) skip(4, "inactive value");
    if (flag == 5) skip(4, "inactive value");
    if (flag == 3 || flag == 4 || flag == 5) skip(mask_bytes, "selection mask");
    const bool active_only = (compression_ & kCompressActiveMask) && flag != 6;
    const std::uint64_t bytes = 4 * (active_only ? active : values);
    const auto block = read<std::int64_t>("node values");
    if (block <= 0) {
      const std::uint64_t raw = 0 - static_cast<std::uint64_t>(block);  // defined for INT64_MIN
      if (raw != bytes)
        damaged("node values of " + std::to_string(raw) + " bytes, expected " +
                std::to_string(bytes));
      skip(bytes, "node values");
    } else {
      skip(static_cast<std::uint64_t>(block), "compressed node values");
    }
  }

  // Passes 0 and 1 of the buffers: each leaf's voxel block size, then the attribute descriptor
  // (once: its header says every leaf shares it) and each leaf's attribute metadata.
  void buffers_metadata(std::uint64_t leaves, std::int64_t samples) {
    const auto passes = read<std::uint16_t>("buffer passes");
    if (leaves == 0) {  // an empty cache: nothing follows that OpenVDB would read
      if (samples != 0) damaged("no points, metadata says " + std::to_string(samples));
      return;
    }
    if (passes != 2 * kAttributes + 4)
      damaged(std::to_string(passes) + " buffer passes, expected " +
              std::to_string(2 * kAttributes + 4));
    skip(2 * leaves, "leaf voxel sizes");
    if (read<std::uint8_t>("attribute descriptor") != 1)
      damaged("attribute descriptor header (leaves not sharing one descriptor)");
    attribute_descriptor();
    std::uint64_t points = 0;
    for (std::uint64_t leaf = 0; leaf < leaves; ++leaf) {
      const std::uint32_t n = leaf_attribute_metadata();
      points += n;
      if (points > static_cast<std::uint64_t>(samples))
        damaged("more points than the " + std::to_string(samples) + " samples its metadata says");
    }
    if (points != static_cast<std::uint64_t>(samples))
      damaged(std::to_string(points) + " points, metadata says " + std::to_string(samples));
  }

  void attribute_descriptor() {
    const auto count = read<std::uint64_t>("attribute count");
    if (count != kAttributes)
      not_ours(std::to_string(count) + " point attributes, dofcache writes " +
               std::to_string(kAttributes));
    std::array<std::string, kAttributes> types;
    for (std::string& type : types) {
      type = string("attribute type");
      if (string("attribute codec") != "null") not_ours("a compressed point attribute");
    }
    std::set<std::uint64_t> positions;
    for (int i = 0; i < kAttributes; ++i) {
      const std::string name = string("attribute name");
      const auto at = read<std::uint64_t>("attribute position");
      auto expected = attribute_types().find(name);
      if (expected == attribute_types().end())
        not_ours("unexpected point attribute '" + printable(name) + "'");
      if (at >= kAttributes || !positions.insert(at).second)
        damaged("attribute '" + name + "' at position " + std::to_string(at));
      if (types[at] != expected->second)
        not_ours("attribute '" + name + "' of type '" + printable(types[at]) + "', not " +
                 expected->second);
      value_size_[at] = types[at] == "vec3s" ? 12 : 4;
    }
    if (read<std::uint64_t>("attribute group count") != 0) not_ours("point groups");
    if (read<std::uint32_t>("attribute descriptor metadata") != 0)
      not_ours("attribute descriptor metadata");
  }

  // A leaf's metadata of each attribute array: its size in bytes, flags, serialisation flags,
  // number of points. Every array of a leaf holds the same points. Returns their number.
  std::uint32_t leaf_attribute_metadata() {
    std::uint32_t points = 0;
    std::array<std::uint64_t, kAttributes> blocks{};
    for (int i = 0; i < kAttributes; ++i) {
      const auto bytes = read<std::uint64_t>("attribute array");
      // Constant stride (0x8) and nothing else (transient, hidden, streaming): without it OpenVDB
      // takes the array for one value in all, and indexing it by point reads past its end (found
      // by fuzzing).
      const auto flags = read<std::uint8_t>("attribute array");
      if (flags != 0x8) damaged("attribute array flags " + std::to_string(flags));
      const auto serialisation = read<std::uint8_t>("attribute array");
      const auto n = read<std::uint32_t>("attribute array");
      // Written in pages (0x8), uniform (0x2) or not; never strided (0x1) or compressed in memory
      // (0x4): dofcache's attributes hold one value per point.
      const bool uniform = serialisation & 0x2;
      if ((serialisation & ~0xa) != 0 || !(serialisation & 0x8))
        damaged("attribute array serialisation flags " + std::to_string(serialisation));
      if (i > 0 && n != points) damaged("attribute arrays of one leaf differ in length");
      points = n;
      // The array's block in its pages: its flags and size (6 bytes), then one value per point,
      // or one value for all if uniform. OpenVDB copies this many bytes into the array, which
      // holds `n` values: any other size would be read or indexed past its end.
      const std::uint64_t block = (uniform ? 1 : std::uint64_t{n}) * value_size_[i];
      if (bytes != 6 + block)
        damaged("attribute array of " + std::to_string(n) + " points in " +
                std::to_string(bytes) + " bytes");
      blocks[i] = block;
    }
    blocks_.push_back(blocks);
    return points;
  }

  // The rest of the buffers. Each attribute's blocks, leaf after leaf, are gathered into pages of
  // about 1 MiB (compression::PagedOutputStream; a larger block is a page of its own): first a pass per attribute of page sizes (an
  // int, negative for an uncompressed page, else the compressed and the uncompressed size), read
  // where a leaf's block starts a page; then the leaves' voxel offsets; then a pass per attribute
  // of the pages' bytes. A block never straddles two pages.
  void buffers_data() {
    std::array<std::vector<Page>, kAttributes> pages;
    for (int i = 0; i < kAttributes; ++i) {
      std::uint64_t used = 0, size = 0;
      for (const auto& blocks : blocks_) {
        if (used == size) {
          Page page;
          page.stored = read<std::int32_t>("attribute page size");
          page.size = page.stored > 0 ? read<std::int32_t>("attribute page size")
                                      : -std::int64_t{page.stored};
          if (page.stored == 0 || page.size <= 0 ||
              (page.stored > 0 && page.stored > page.size + kBloscHeader))
            damaged("attribute page of " + std::to_string(page.stored) + " and " +
                    std::to_string(page.size) + " bytes");
          pages[i].push_back(page);
          used = 0;
          size = static_cast<std::uint64_t>(page.size);
        }
        used += blocks[i];
        if (used > size) damaged("an attribute array crosses its page");
      }
      if (used != size) damaged("attribute page not filled by its arrays");
    }
    for (std::size_t leaf = 0; leaf < blocks_.size(); ++leaf) {
      skip(64, "leaf value mask");
      // 512 voxel offsets (u32): 0xffff for uncompressed, else the blosc block's size.
      const auto stored = read<std::uint16_t>("leaf voxel offsets");
      if (stored == 0xffff)
        skip(2048, "leaf voxel offsets");
      else
        blosc_block(stored, 2048, "leaf voxel offsets");
    }
    for (int i = 0; i < kAttributes; ++i) {
      for (const Page& page : pages[i]) {
        if (page.stored < 0)
          skip(static_cast<std::uint64_t>(page.size), "attribute page");
        else
          blosc_block(static_cast<std::uint64_t>(page.stored),
                      static_cast<std::uint64_t>(page.size), "attribute page");
      }
    }
  }

  // A blosc block of `stored` bytes that must expand to `size` bytes. Blosc believes its own
  // header (sizes, block size) over the buffer it is given: a forged header made it read past
  // the buffer (found by fuzzing). So the header must agree with the sizes around it.
  void blosc_block(std::uint64_t stored, std::uint64_t size, const std::string& what) {
    need(stored, what);
    if (stored < kBloscHeader) damaged(what + ": blosc block of " + std::to_string(stored) + " bytes");
    const char* h = data_.data() + pos_;
    const auto flags = static_cast<std::uint8_t>(h[2]);
    std::uint32_t nbytes, blocksize, cbytes;
    std::memcpy(&nbytes, h + 4, 4);
    std::memcpy(&blocksize, h + 8, 4);
    std::memcpy(&cbytes, h + 12, 4);
    const bool copied = flags & 0x2;  // stored uncompressed after the header
    if (nbytes != size || cbytes != stored || blocksize == 0 || blocksize > nbytes ||
        (copied && stored != kBloscHeader + size))
      damaged(what + ": blosc header does not match its " + std::to_string(stored) +
              " bytes holding " + std::to_string(size));
    pos_ += stored;
  }

  struct Page {
    std::int64_t stored = 0;  // bytes in the file: negative if uncompressed
    std::int64_t size = 0;    // bytes once uncompressed
  };
  static constexpr std::int64_t kBloscHeader = 16;     // blosc 1.x: BLOSC_MAX_OVERHEAD

  const std::string& path_;
  std::string_view data_;
  std::uint64_t pos_ = 0;
  std::uint32_t compression_ = 0;
  std::array<std::uint64_t, kAttributes> value_size_{};              // by attribute position
  std::vector<std::array<std::uint64_t, kAttributes>> blocks_;  // per leaf, by position
};

}  // namespace

void check_cache_file_layout(const std::string& path, std::string_view vdb) {
  LayoutWalker(path, vdb).walk();
}

}  // namespace dofcache::sequence
