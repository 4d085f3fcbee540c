#include "dofcache/cache/trace.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <memory>

#include "dofcache/core/error.h"

namespace dofcache::cache {
namespace {

constexpr char kMagic[8] = {'D', 'O', 'F', 'C', 'T', 'R', 'C', '\0'};
constexpr std::uint32_t kVersion = 2;  // 2: the anisotropic footprint (1 is read too)
enum class Tag : std::uint32_t { End = 0, Lookups = 1, Inserts = 2 };
constexpr std::size_t kLookupBytes = 24, kInsertBytes = 44;

// The format is little-endian, as are the machines we build for; fields are copied one by one so
// that struct padding never reaches the file.
static_assert(sizeof(float) == 4 && sizeof(std::uint32_t) == 4);

template <typename T>
void put(std::vector<unsigned char>* buf, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  buf->insert(buf->end(), b, b + sizeof(T));
}
void put3(std::vector<unsigned char>* buf, glm::vec3 v) {
  put(buf, v.x);
  put(buf, v.y);
  put(buf, v.z);
}

class Reader {
 public:
  Reader(const std::string& path, std::FILE* f) : path_(path), f_(f) {
    if (std::fseek(f, 0, SEEK_END) == 0) {
      long size = std::ftell(f);
      if (size >= 0) remaining_ = static_cast<std::size_t>(size);
    }
    std::rewind(f);
  }
  // Checks a record's size against what the file holds before anything is allocated for it.
  void expect(std::size_t bytes) {
    if (bytes > remaining_) throw Error("cache trace " + path_ + ": truncated");
  }
  void read(void* dst, std::size_t bytes) {
    expect(bytes);
    if (std::fread(dst, 1, bytes, f_) != bytes) throw Error("cache trace " + path_ + ": truncated");
    remaining_ -= bytes;
  }
  template <typename T>
  T get() {
    T v;
    read(&v, sizeof v);
    return v;
  }

 private:
  const std::string& path_;
  std::FILE* f_;
  std::size_t remaining_ = 0;
};

}  // namespace

std::size_t CacheTrace::lookup_count() const {
  std::size_t n = 0;
  for (const TracePass& p : passes) n += p.lookups.size();
  return n;
}

std::size_t CacheTrace::insert_count() const {
  std::size_t n = 0;
  for (const TracePass& p : passes) n += p.inserts.size();
  return n;
}

TraceWriter::TraceWriter(const std::string& path, const LookupOptions& options) : path_(path) {
  file_ = std::fopen(path.c_str(), "wb");
  if (!file_) throw Error("cache trace " + path + ": cannot open for writing");
  std::vector<unsigned char> buf(kMagic, kMagic + 8);
  put(&buf, kVersion);
  put(&buf, options.max_normal_angle_deg);
  put(&buf, static_cast<std::int32_t>(options.min_samples));
  put(&buf, static_cast<std::uint32_t>(options.reject_in_front ? 1 : 0));
  put(&buf, options.front_tolerance);
  put(&buf, options.footprint_squeeze);
  put3(&buf, options.footprint_axis);
  put3(&buf, options.camera_position);
  put3(&buf, options.camera_forward);
  put(&buf, options.floor_per_depth);
  write(buf.data(), buf.size());
}

TraceWriter::~TraceWriter() {
  if (!file_) return;
  try {
    close();
  } catch (const Error&) {
    // A destructor cannot report; callers who care call close() themselves.
  }
}

void TraceWriter::write(const void* data, std::size_t bytes) {
  if (std::fwrite(data, 1, bytes, file_) != bytes)
    throw Error("cache trace " + path_ + ": write failed");
}

void TraceWriter::add_lookups(const std::vector<TraceLookup>& lookups) {
  std::vector<unsigned char> buf;
  buf.reserve(8 + lookups.size() * kLookupBytes);
  put(&buf, static_cast<std::uint32_t>(Tag::Lookups));
  put(&buf, static_cast<std::uint32_t>(lookups.size()));
  for (const TraceLookup& l : lookups) {
    put3(&buf, l.position);
    put3(&buf, l.normal);
  }
  write(buf.data(), buf.size());
}

void TraceWriter::add_inserts(const std::vector<CacheSample>& batch) {
  std::vector<unsigned char> buf;
  buf.reserve(8 + batch.size() * kInsertBytes);
  put(&buf, static_cast<std::uint32_t>(Tag::Inserts));
  put(&buf, static_cast<std::uint32_t>(batch.size()));
  for (const CacheSample& s : batch) {
    put3(&buf, s.position);
    put3(&buf, s.normal);
    put3(&buf, s.value);
    put(&buf, s.radius);
    put(&buf, s.frame);
  }
  write(buf.data(), buf.size());
}

void TraceWriter::close() {
  if (!file_) return;
  std::vector<unsigned char> buf;
  put(&buf, static_cast<std::uint32_t>(Tag::End));
  put(&buf, std::uint32_t{0});
  write(buf.data(), buf.size());
  bool ok = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok) throw Error("cache trace " + path_ + ": write failed");
}

void write_trace(const std::string& path, const CacheTrace& trace) {
  TraceWriter writer(path, trace.options);
  for (const TracePass& pass : trace.passes) {
    if (!pass.lookups.empty()) writer.add_lookups(pass.lookups);
    writer.add_inserts(pass.inserts);  // closes the pass, even when empty
  }
  writer.close();
}

CacheTrace read_trace(const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) throw Error("cache trace " + path + ": cannot open");
  Reader in(path, file.get());
  char magic[8];
  in.read(magic, 8);
  if (std::memcmp(magic, kMagic, 8) != 0) throw Error("cache trace " + path + ": not a trace");
  auto version = in.get<std::uint32_t>();
  if (version != 1 && version != kVersion)
    throw Error("cache trace " + path + ": version " + std::to_string(version) +
                " not supported (expected 1 or " + std::to_string(kVersion) + ")");
  CacheTrace trace;
  trace.options.max_normal_angle_deg = in.get<float>();
  trace.options.min_samples = in.get<std::int32_t>();
  trace.options.reject_in_front = in.get<std::uint32_t>() != 0;
  trace.options.front_tolerance = in.get<float>();
  if (version >= 2) {
    LookupOptions& o = trace.options;
    auto get3 = [&] {
      const float x = in.get<float>(), y = in.get<float>(), z = in.get<float>();
      return glm::vec3(x, y, z);
    };
    o.footprint_squeeze = in.get<float>();
    o.footprint_axis = get3();
    o.camera_position = get3();
    o.camera_forward = get3();
    o.floor_per_depth = in.get<float>();
    const float values[] = {o.footprint_axis.x, o.footprint_axis.y, o.footprint_axis.z,
                            o.camera_position.x, o.camera_position.y, o.camera_position.z,
                            o.camera_forward.x, o.camera_forward.y, o.camera_forward.z,
                            o.floor_per_depth};
    if (!(o.footprint_squeeze > 0.0f && o.footprint_squeeze <= 1.0f) ||
        !std::all_of(std::begin(values), std::end(values), [](float v) { return std::isfinite(v); }) ||
        !(o.floor_per_depth >= 0.0f))
      throw Error("cache trace " + path + ": its footprint is not a squeeze in (0, 1] with finite axes");
  }

  TracePass pass;
  bool open = false;
  for (;;) {
    auto tag = static_cast<Tag>(in.get<std::uint32_t>());
    auto count = in.get<std::uint32_t>();
    if (tag == Tag::End) break;
    if (tag == Tag::Lookups) {
      in.expect(std::size_t{count} * kLookupBytes);
      std::vector<float> buf(std::size_t{count} * 6);
      in.read(buf.data(), buf.size() * sizeof(float));
      for (std::size_t i = 0; i < count; ++i) {
        const float* f = &buf[i * 6];
        pass.lookups.push_back({{f[0], f[1], f[2]}, {f[3], f[4], f[5]}});
      }
      open = true;
    } else if (tag == Tag::Inserts) {
      in.expect(std::size_t{count} * kInsertBytes);
      std::vector<float> buf(std::size_t{count} * 11);
      in.read(buf.data(), buf.size() * sizeof(float));
      for (std::size_t i = 0; i < count; ++i) {
        const float* f = &buf[i * 11];
        CacheSample s;
        s.position = {f[0], f[1], f[2]};
        s.normal = {f[3], f[4], f[5]};
        s.value = {f[6], f[7], f[8]};
        s.radius = f[9];
        std::memcpy(&s.frame, &f[10], sizeof s.frame);
        pass.inserts.push_back(s);
      }
      trace.passes.push_back(std::move(pass));
      pass = TracePass{};
      open = false;
    } else {
      throw Error("cache trace " + path + ": unknown record tag " +
                  std::to_string(static_cast<std::uint32_t>(tag)));
    }
  }
  if (open) trace.passes.push_back(std::move(pass));
  return trace;
}

}  // namespace dofcache::cache
