// Radiance cache files through OpenVDB's file I/O (layout in cache_file.h and docs/sequence.md).
// The only translation unit of the sequence module that includes OpenVDB.
#include "dofcache/sequence/cache_file.h"

#include "cache_file_layout.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include <glm/geometric.hpp>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/PointAttribute.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>
#include <openvdb/tools/PointIndexGrid.h>

#include "dofcache/core/atomic_file.h"
#include "dofcache/core/content_hash.h"
#include "dofcache/core/error.h"
#include "dofcache/core/file.h"
#include "dofcache/core/rng.h"

namespace dofcache::sequence {
namespace {

namespace vdb = openvdb;
using vdb::points::PointDataGrid;
using vdb::points::PointDataTree;

constexpr const char* kFormatName = "dofcache radiance cache";
constexpr const char* kGridName = "samples";
constexpr char kTrailerMagic[8] = {'D', 'O', 'F', 'C', 'S', 'U', 'M', '1'};
constexpr std::size_t kTrailerSize = 24;

constexpr std::uint64_t kTrailerHashSeed = 0x646f6663616368ULL;  // "dofcach"

std::string hex64(std::uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

bool parse_hex64(const std::string& s, std::uint64_t* v) {
  if (s.size() != 16) return false;
  std::uint64_t r = 0;
  for (char c : s) {
    int d = (c >= '0' && c <= '9') ? c - '0' : (c >= 'a' && c <= 'f') ? c - 'a' + 10 : -1;
    if (d < 0) return false;
    r = r << 4 | static_cast<std::uint64_t>(d);
  }
  *v = r;
  return true;
}

// The voxel size of the point grid: a power of two (so P, stored relative to its voxel, converts
// back to exactly the same float) giving about 256 voxels across the samples' extent.
double voxel_size_for(const std::vector<vdb::Vec3f>& positions) {
  float extent = 0.0f;
  for (const vdb::Vec3f& p : positions)
    extent = std::max({extent, std::abs(p.x()), std::abs(p.y()), std::abs(p.z())});
  if (!(extent > 0.0f)) return 1.0;
  int e = static_cast<int>(std::ceil(std::log2(double(extent) / 256.0)));
  return std::ldexp(1.0, std::clamp(e, -30, 30));
}

template <class T>
void add_attribute(PointDataTree& tree, const vdb::tools::PointIndexTree& index,
                   const std::string& name, const std::vector<T>& values) {
  vdb::points::appendAttribute<T>(tree, name);
  vdb::points::populateAttribute(tree, index, name, vdb::points::PointAttributeVector<T>(values));
}

void write_vdb(const std::string& path, const CacheFile& file) {
  vdb::initialize();
  const std::size_t n = file.records.size();
  std::vector<vdb::Vec3f> position(n), normal(n), value(n);
  std::vector<float> radius(n), base_radius(n), view_radius(n), footprint(n);
  std::vector<std::int32_t> id(n), frame(n), last_used(n);
  for (std::size_t i = 0; i < n; ++i) {
    const cache::SampleRecord& r = file.records[i];
    const cache::CacheSample& s = r.sample;
    position[i] = {s.position.x, s.position.y, s.position.z};
    normal[i] = {s.normal.x, s.normal.y, s.normal.z};
    value[i] = {s.value.x, s.value.y, s.value.z};
    radius[i] = s.radius;
    base_radius[i] = r.origin.radius;
    view_radius[i] = r.origin.view_radius;
    footprint[i] = r.origin.footprint;
    std::memcpy(&id[i], &s.id, 4);  // uint32 stored as its int32 bit pattern
    std::memcpy(&frame[i], &s.frame, 4);
    last_used[i] = r.last_used;
  }
  vdb::math::Transform::Ptr xform =
      vdb::math::Transform::createLinearTransform(voxel_size_for(position));
  vdb::points::PointAttributeVector<vdb::Vec3f> wrapper(position);
  auto index = vdb::tools::createPointIndexGrid<vdb::tools::PointIndexGrid>(wrapper, *xform);
  PointDataGrid::Ptr grid =
      vdb::points::createPointDataGrid<vdb::points::NullCodec, PointDataGrid>(*index, wrapper,
                                                                              *xform);
  PointDataTree& tree = grid->tree();
  const auto& itree = index->tree();
  add_attribute(tree, itree, "N", normal);
  add_attribute(tree, itree, "value", value);
  add_attribute(tree, itree, "radius", radius);
  add_attribute(tree, itree, "base_radius", base_radius);
  add_attribute(tree, itree, "view_radius", view_radius);
  add_attribute(tree, itree, "footprint", footprint);
  add_attribute(tree, itree, "id", id);
  add_attribute(tree, itree, "frame", frame);
  add_attribute(tree, itree, "last_used", last_used);
  grid->setName(kGridName);

  vdb::MetaMap meta;
  meta.insertMeta("dofcache.format", vdb::StringMetadata(kFormatName));
  meta.insertMeta("dofcache.version", vdb::Int32Metadata(kCacheFileVersion));
  meta.insertMeta("dofcache.scene_hash", vdb::StringMetadata(hex64(file.identity.scene_hash)));
  meta.insertMeta("dofcache.environment_hash",
                  vdb::StringMetadata(hex64(file.identity.environment_hash)));
  meta.insertMeta("dofcache.scene", vdb::StringMetadata(file.scene_source));
  meta.insertMeta("dofcache.light_samples", vdb::Int32Metadata(file.identity.light_samples));
  meta.insertMeta("dofcache.gather_rays", vdb::Int32Metadata(file.identity.gather_rays));
  meta.insertMeta("dofcache.bounces", vdb::Int32Metadata(file.identity.bounces));
  meta.insertMeta("dofcache.sample_quality", vdb::Int32Metadata(file.identity.sample_quality));
  meta.insertMeta("dofcache.min_factor", vdb::DoubleMetadata(file.min_factor));
  meta.insertMeta("dofcache.sample_count", vdb::Int64Metadata(static_cast<std::int64_t>(n)));
  if (file.lens.design != 0) {
    meta.insertMeta("dofcache.lens_design", vdb::StringMetadata(hex64(file.lens.design)));
    meta.insertMeta("dofcache.lens", vdb::StringMetadata(file.lens.description));
  }
  if (file.checkpoint) {
    meta.insertMeta("dofcache.sequence_key",
                    vdb::StringMetadata(hex64(file.checkpoint->sequence_key)));
    meta.insertMeta("dofcache.first_frame", vdb::Int32Metadata(file.checkpoint->first_frame));
    meta.insertMeta("dofcache.frame", vdb::Int32Metadata(file.checkpoint->frame));
  }
  vdb::io::File out(path);
  out.setCompression(vdb::io::Archive::hasBloscCompression()
                         ? (vdb::io::COMPRESS_BLOSC | vdb::io::COMPRESS_ACTIVE_MASK)
                         : (vdb::io::COMPRESS_ZIP | vdb::io::COMPRESS_ACTIVE_MASK));
  out.write(vdb::GridCPtrVec{grid}, meta);
  out.close();
}

}  // namespace

void append_cache_file_trailer(const std::string& path) {
  std::string data = read_file(path, "cache file");
  std::uint64_t length = data.size();
  std::uint64_t hash = hash_bytes(data.data(), data.size(), kTrailerHashSeed);
  char trailer[kTrailerSize];
  std::memcpy(trailer, kTrailerMagic, 8);
  std::memcpy(trailer + 8, &length, 8);
  std::memcpy(trailer + 16, &hash, 8);
  std::ofstream out(path, std::ios::binary | std::ios::app);
  out.write(trailer, kTrailerSize);
  out.close();
  if (!out) throw Error(path + ": cannot write the cache file");
}

namespace {

// Checks the trailer: the file is complete and unchanged since it was written. Returns the file.
std::string check_integrity(const std::string& path) {
  std::string data = read_file(path, "cache file");
  if (data.size() < kTrailerSize || std::memcmp(data.data() + data.size() - kTrailerSize,
                                                kTrailerMagic, 8) != 0)
    throw Error(path + ": not a dofcache cache file, or truncated (no dofcache trailer)");
  std::uint64_t length, hash;
  std::memcpy(&length, data.data() + data.size() - 16, 8);
  std::memcpy(&hash, data.data() + data.size() - 8, 8);
  if (length != data.size() - kTrailerSize)
    throw Error(path + ": cache file is damaged (length does not match its trailer)");
  if (hash != hash_bytes(data.data(), length, kTrailerHashSeed))
    throw Error(path + ": cache file is damaged (checksum mismatch)");
  data.resize(length);
  return data;
}

class MetaReader {
 public:
  MetaReader(const vdb::MetaMap& meta, std::string path) : meta_(meta), path_(std::move(path)) {}

  bool has(const std::string& key) const { return meta_[key] != nullptr; }
  std::string string(const std::string& key) const {
    auto m = meta_.getMetadata<vdb::StringMetadata>(key);
    if (!m) missing(key);
    return m->value();
  }
  std::int32_t int32(const std::string& key) const {
    auto m = meta_.getMetadata<vdb::Int32Metadata>(key);
    if (!m) missing(key);
    return m->value();
  }
  std::int64_t int64(const std::string& key) const {
    auto m = meta_.getMetadata<vdb::Int64Metadata>(key);
    if (!m) missing(key);
    return m->value();
  }
  double real(const std::string& key) const {
    auto m = meta_.getMetadata<vdb::DoubleMetadata>(key);
    if (!m) missing(key);
    return m->value();
  }
  std::uint64_t hex(const std::string& key) const {
    std::uint64_t v = 0;
    if (!parse_hex64(string(key), &v)) throw Error(path_ + ": metadata " + key + " is malformed");
    return v;
  }

 private:
  [[noreturn]] void missing(const std::string& key) const {
    throw Error(path_ + ": not a dofcache cache file (metadata " + key + " missing or mistyped)");
  }
  const vdb::MetaMap& meta_;
  std::string path_;
};

CacheFile read_vdb(const std::string& path, std::uint64_t max_samples) {
  vdb::initialize();
  vdb::io::File in(path);
  in.open(/*delayLoad=*/false);
  vdb::MetaMap::Ptr meta = in.getMetadata();
  MetaReader m(*meta, path);
  if (!m.has("dofcache.format") || m.string("dofcache.format") != kFormatName)
    throw Error(path + ": not a dofcache cache file (an OpenVDB file without dofcache metadata)");
  int version = m.int32("dofcache.version");
  if (version != kCacheFileVersion)
    throw Error(path + ": cache file format version " + std::to_string(version) +
                " is not supported (this build reads version " + std::to_string(kCacheFileVersion) +
                ")");
  CacheFile file;
  file.identity.scene_hash = m.hex("dofcache.scene_hash");
  if (m.has("dofcache.environment_hash"))  // written since environments exist
    file.identity.environment_hash = m.hex("dofcache.environment_hash");
  file.scene_source = m.string("dofcache.scene");
  file.identity.light_samples = m.int32("dofcache.light_samples");
  file.identity.gather_rays = m.int32("dofcache.gather_rays");
  file.identity.bounces = m.int32("dofcache.bounces");
  file.identity.sample_quality = m.int32("dofcache.sample_quality");
  file.min_factor = m.real("dofcache.min_factor");
  const std::int64_t count = m.int64("dofcache.sample_count");
  if (count < 0)
    throw Error(path + ": cache file is damaged (sample count " + std::to_string(count) + ")");
  if (static_cast<std::uint64_t>(count) > max_samples)
    throw Error(path + ": cache file declares " + std::to_string(count) +
                " samples, more than the limit of " + std::to_string(max_samples));
  if (m.has("dofcache.lens_design")) {  // written since lenses are recorded
    file.lens.design = m.hex("dofcache.lens_design");
    if (file.lens.design == 0) throw Error(path + ": metadata dofcache.lens_design is malformed");
    file.lens.description = m.string("dofcache.lens");
  }
  if (m.has("dofcache.sequence_key")) {
    SequenceCheckpoint cp;
    cp.sequence_key = m.hex("dofcache.sequence_key");
    cp.first_frame = m.int32("dofcache.first_frame");
    cp.frame = m.int32("dofcache.frame");
    file.checkpoint = cp;
  }

  if (!in.hasGrid(kGridName)) throw Error(path + ": cache file has no '" + kGridName + "' grid");
  vdb::GridBase::Ptr base = in.readGrid(kGridName);
  in.close();
  PointDataGrid::Ptr grid = vdb::gridPtrCast<PointDataGrid>(base);
  if (!grid) throw Error(path + ": the '" + std::string(kGridName) + "' grid is not a point grid");
  const vdb::math::Transform& xform = grid->transform();
  // Reserve for the points the grid holds, never for what the metadata claims.
  const vdb::Index64 points = vdb::points::pointCount(grid->tree());
  if (points != static_cast<vdb::Index64>(count))
    throw Error(path + ": cache file is damaged (" + std::to_string(points) +
                " samples, metadata says " + std::to_string(count) + ")");
  file.records.reserve(static_cast<std::size_t>(points));
  for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) {
    // The voxels' offsets index the attribute arrays below: increasing, ending at their length.
    leaf->validateOffsets();
    using vdb::points::AttributeHandle;
    auto p = AttributeHandle<vdb::Vec3f>::create(leaf->constAttributeArray("P"));
    auto nrm = AttributeHandle<vdb::Vec3f>::create(leaf->constAttributeArray("N"));
    auto val = AttributeHandle<vdb::Vec3f>::create(leaf->constAttributeArray("value"));
    auto rad = AttributeHandle<float>::create(leaf->constAttributeArray("radius"));
    auto base_rad = AttributeHandle<float>::create(leaf->constAttributeArray("base_radius"));
    auto view_rad = AttributeHandle<float>::create(leaf->constAttributeArray("view_radius"));
    auto foot = AttributeHandle<float>::create(leaf->constAttributeArray("footprint"));
    auto ids = AttributeHandle<std::int32_t>::create(leaf->constAttributeArray("id"));
    auto frames = AttributeHandle<std::int32_t>::create(leaf->constAttributeArray("frame"));
    auto used = AttributeHandle<std::int32_t>::create(leaf->constAttributeArray("last_used"));
    for (auto idx = leaf->beginIndexAll(); idx; ++idx) {
      if (static_cast<std::int64_t>(file.records.size()) >= count)
        throw Error(path + ": cache file is damaged (more samples than its metadata says)");
      const vdb::Index i = *idx;
      vdb::Vec3d w = xform.indexToWorld(idx.getCoord().asVec3d() + vdb::Vec3d(p->get(i)));
      cache::SampleRecord r;
      cache::CacheSample& s = r.sample;
      s.position = glm::vec3(static_cast<float>(w.x()), static_cast<float>(w.y()),
                             static_cast<float>(w.z()));
      vdb::Vec3f nv = nrm->get(i), vv = val->get(i);
      s.normal = glm::vec3(nv.x(), nv.y(), nv.z());
      s.value = glm::vec3(vv.x(), vv.y(), vv.z());
      s.radius = rad->get(i);
      r.origin.radius = base_rad->get(i);
      r.origin.view_radius = view_rad->get(i);
      r.origin.footprint = foot->get(i);
      std::int32_t id = ids->get(i), fr = frames->get(i);
      std::memcpy(&s.id, &id, 4);
      std::memcpy(&s.frame, &fr, 4);
      r.last_used = used->get(i);
      file.records.push_back(r);
    }
  }
  if (static_cast<std::int64_t>(file.records.size()) != count)
    throw Error(path + ": cache file is damaged (" + std::to_string(file.records.size()) +
                " samples, metadata says " + std::to_string(count) + ")");
  return file;
}

void validate_records(CacheFile& file, const std::string& path) {
  std::sort(file.records.begin(), file.records.end(),
            [](const cache::SampleRecord& a, const cache::SampleRecord& b) { return a.sample.id < b.sample.id; });
  for (std::size_t i = 0; i < file.records.size(); ++i) {
    const cache::CacheSample& s = file.records[i].sample;
    if (!valid_sample_record(file.records[i]))
      throw Error(path + ": cache file holds an invalid sample (id " + std::to_string(s.id) +
                  ": non-finite value, non-unit normal or non-positive radius)");
    if (i > 0 && file.records[i - 1].sample.id == s.id)
      throw Error(path + ": cache file holds two samples with id " + std::to_string(s.id));
  }
}

}  // namespace

bool valid_sample_record(const cache::SampleRecord& r) {
  auto finite3 = [](glm::vec3 v) {
    return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
  };
  const cache::CacheSample& s = r.sample;
  float nl = std::sqrt(glm::dot(s.normal, s.normal));
  return finite3(s.position) && finite3(s.value) && std::abs(nl - 1.0f) < 1e-3f &&
         s.radius > 0.0f && std::isfinite(s.radius) && r.origin.radius > 0.0f &&
         std::isfinite(r.origin.radius) && r.origin.view_radius > 0.0f &&
         std::isfinite(r.origin.view_radius) && r.origin.footprint >= 0.0f &&
         std::isfinite(r.origin.footprint);
}

CacheIdentity cache_identity(const scene::Scene& scene, const render::RenderSettings& settings) {
  CacheIdentity id;
  id.scene_hash = scene.content_hash;
  if (settings.shading.environment) id.environment_hash = settings.shading.environment->content_hash();
  id.light_samples = settings.shading.light_samples;
  id.gather_rays = settings.shading.gather_rays;
  id.bounces = settings.shading.bounces;
  id.sample_quality = render::effective_sample_quality(settings);
  return id;
}

void write_cache_file(const std::string& path, const CacheFile& file) {
  try {
    write_atomically(path, [&](const std::string& tmp) {
      write_vdb(tmp, file);
      append_cache_file_trailer(tmp);
    });
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot write the cache file (" + e.what() + ")");
  }
}

CacheFile read_cache_file(const std::string& path, std::uint64_t max_samples) {
  // The trailer catches accidental damage; the layout walk catches forged files (sealed with a
  // valid trailer) before OpenVDB allocates what they declare.
  check_cache_file_layout(path, check_integrity(path));
  CacheFile file;
  try {
    file = read_vdb(path, max_samples);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // openvdb::Exception derives from std::exception
    throw Error(path + ": not a readable dofcache cache file (" + e.what() + ")");
  }
  validate_records(file, path);
  return file;
}

void check_cache_identity(const CacheFile& file, const CacheIdentity& expected,
                          const std::string& path) {
  const CacheIdentity& got = file.identity;
  if (got.scene_hash != expected.scene_hash)
    throw Error(path + ": the cache was made for another scene ('" + file.scene_source +
                "', content hash " + hex64(got.scene_hash) + "; this scene's is " +
                hex64(expected.scene_hash) + ")");
  if (got.environment_hash != expected.environment_hash) {
    auto name = [](std::uint64_t h) { return h == 0 ? std::string("none") : hex64(h); };
    throw Error(path + ": the cache was made under another environment light (content hash " +
                name(got.environment_hash) + "; this render's is " +
                name(expected.environment_hash) +
                "; cached values depend on it: use the same --env options or a new cache)");
  }
  auto differs = [&](const char* what, int a, int b) {
    if (a != b)
      throw Error(path + ": the cache was made with " + what + " " + std::to_string(a) +
                  ", this render uses " + std::to_string(b) +
                  " (cached values depend on it; use the same setting or a new cache)");
  };
  differs("--light-samples", got.light_samples, expected.light_samples);
  differs("--gather-rays", got.gather_rays, expected.gather_rays);
  differs("--bounces", got.bounces, expected.bounces);
  differs("--cache-sample-quality", got.sample_quality, expected.sample_quality);
}

void check_cache_lens(const CacheFile& file, const lens::LensIdentity& expected,
                      const std::string& path, bool any_lens) {
  if (any_lens || file.lens.design == 0 || file.lens.design == expected.design) return;
  throw Error(path + ": the cache was made through another lens (" + file.lens.description +
              "; this render's: " + expected.description +
              "); cached values do not depend on the lens, so --cache-any-lens reuses it");
}

}  // namespace dofcache::sequence
