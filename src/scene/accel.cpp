// Embree 3: one device, one static scene, one triangle geometry over Scene::mesh.
#include "dofcache/scene/accel.h"

#include <embree3/rtcore.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include "dofcache/core/error.h"
#include "dofcache/core/rng.h"

namespace dofcache::scene {
namespace {

// Triangles whose material is alpha-tested (MASK or BLEND) go into Embree geometries that have
// the filter function; the rest (nearly always all) into ones without, which Embree traces at
// full speed. Each geometry is a run of consecutive scene triangles of one kind that shares
// Scene::mesh.triangles: the loader appends a primitive's triangles together, so runs are few
// and no index is copied (a copy was 16 bytes per triangle, a quarter of Embree's own BVH). Where
// runs are many and short, the triangles are copied into two geometries instead (plain and
// alpha-tested), since an Embree geometry costs far more than a triangle's indices.
// Culling the back faces of single-sided materials, which only camera rays do, is a re-trace past
// the culled hit (Accel::intersect), not a filter on every triangle.
constexpr unsigned kPlainGeometry = 0, kAlphaGeometry = 1;  // the copies' geometries

// The query's context: Embree hands it to the filter function (it must start with Embree's own).
struct QueryContext {
  RTCIntersectContext embree;
  std::uint64_t ray_key = 0;  // the ray's seed, origin and direction hashed: BLEND draws
};

std::uint32_t bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

std::uint64_t ray_key(const Ray& ray) {
  std::uint64_t h = hash_combine(0x626c656e64ULL, ray.seed);  // "blend"
  h = hash_combine(h, (std::uint64_t{bits(ray.origin.x)} << 32) | bits(ray.origin.y));
  h = hash_combine(h, (std::uint64_t{bits(ray.origin.z)} << 32) | bits(ray.direction.x));
  return hash_combine(h, (std::uint64_t{bits(ray.direction.y)} << 32) | bits(ray.direction.z));
}

const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}

}  // namespace

struct Accel::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  const Scene* source = nullptr;
  std::vector<float> padded_positions;  // only when Scene::mesh.positions cannot be shared
  std::vector<std::uint8_t> single_sided;  // per scene triangle: culled from behind by camera rays
  // Embree geometry g holds the scene triangles run_first[g] + prim (runs sharing
  // Scene::mesh.triangles) or, where the triangles were copied (run_first empty),
  // triangle_of[g][prim], with indices[g] its index buffer.
  std::vector<std::uint32_t> run_first;
  std::vector<glm::uvec3> indices[2];
  std::vector<std::uint32_t> triangle_of[2];
  bool alpha_tested = false;  // some triangles are: rays need their key for BLEND draws

  std::uint32_t scene_triangle(unsigned geometry, unsigned prim) const {
    return run_first.empty() ? triangle_of[geometry][prim] : run_first[geometry] + prim;
  }

  // Embree geometry `id`: `count` triangles of `index` over the shared vertex buffer, with the
  // alpha filter function if `alpha`.
  void attach(unsigned id, const void* vertices, std::size_t vertex_count,
              const glm::uvec3* index, std::size_t count, bool alpha) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices, 0,
                               3 * sizeof(float), vertex_count);
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, index, 0,
                               3 * sizeof(std::uint32_t), count);
    if (alpha) {
      rtcSetGeometryUserData(geom, this);
      rtcSetGeometryIntersectFilterFunction(geom, &Impl::filter);
      rtcSetGeometryOccludedFilterFunction(geom, &Impl::filter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene, geom, id);
    rtcReleaseGeometry(geom);  // the scene holds it now
  }

  // Embree reports errors through a C callback. Throwing through Embree's C API is not safe, so
  // the callback records the first message and check() turns it into a dofcache::Error.
  std::mutex mutex;
  std::string error;

  static void on_error(void* user, RTCError code, const char* message) {
    auto* self = static_cast<Impl*>(user);
    std::lock_guard<std::mutex> lock(self->mutex);
    if (self->error.empty())
      self->error =
          std::string(error_name(code)) + (message && *message ? std::string(": ") + message : "");
  }

  void check(const char* what) {
    std::string message;
    {
      std::lock_guard<std::mutex> lock(mutex);
      message.swap(error);
    }
    RTCError code = device ? rtcGetDeviceError(device) : rtcGetDeviceError(nullptr);
    if (message.empty() && code != RTC_ERROR_NONE) message = error_name(code);
    if (!message.empty()) throw Error(std::string("Embree: ") + what + ": " + message);
  }

  // Embree's filter function of the alpha-tested geometry (intersection and occlusion alike):
  // rejects a candidate hit where a MASK material is cut out, and where a BLEND material lets the
  // ray through (probability 1 - alpha, drawn from the ray's key and the triangle, so the same
  // ray always gets the same answer).
  static void filter(const RTCFilterFunctionNArguments* args) {
    const auto* im = static_cast<const Impl*>(args->geometryUserPtr);
    const auto* context = reinterpret_cast<const QueryContext*>(args->context);
    const Scene& s = *im->source;
    for (unsigned i = 0; i < args->N; ++i) {
      if (args->valid[i] != -1) continue;
      const std::uint32_t t = im->scene_triangle(RTCHitN_geomID(args->hit, args->N, i),
                                                 RTCHitN_primID(args->hit, args->N, i));
      const float alpha =
          s.alpha_at(t, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i));
      const Material& m = s.materials[s.mesh.triangle_material[t]];
      if (m.alpha_mode == AlphaMode::Mask) {
        if (!(alpha >= m.alpha_cutoff)) args->valid[i] = 0;
      } else {
        const std::uint64_t h = hash_combine(context->ray_key, t);
        const float u = static_cast<float>(h >> 40) * 0x1p-24f;  // uniform in [0, 1)
        if (!(u < alpha)) args->valid[i] = 0;
      }
    }
  }

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

Accel::Accel(const Scene& s) : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  im.device = rtcNewDevice(nullptr);
  if (!im.device) im.check("creating the device");
  rtcSetDeviceErrorFunction(im.device, &Impl::on_error, &im);

  im.scene = rtcNewScene(im.device);
  rtcSetSceneFlags(im.scene, RTC_SCENE_FLAG_ROBUST);  // no precision-reducing shortcuts
  rtcSetSceneBuildQuality(im.scene, RTC_BUILD_QUALITY_HIGH);
  im.check("creating the scene");

  const Mesh& mesh = s.mesh;
  const std::size_t n = mesh.triangles.size();
  im.source = &s;
  im.single_sided.assign(n, 0);
  std::vector<std::uint8_t> alpha(n, 0);
  std::vector<std::uint32_t> runs;  // the first triangle of each run of one kind
  for (std::size_t t = 0; t < n; ++t) {
    const std::uint32_t material = t < mesh.triangle_material.size() ? mesh.triangle_material[t] : 0;
    if (material < s.materials.size()) {
      const Material& m = s.materials[material];
      im.single_sided[t] = !m.double_sided;
      alpha[t] = m.alpha_mode != AlphaMode::Opaque;
    }
    im.alpha_tested = im.alpha_tested || alpha[t];
    if (t == 0 || alpha[t] != alpha[t - 1]) runs.push_back(static_cast<std::uint32_t>(t));
  }
  // An Embree geometry takes about a kilobyte: shared runs while they average hundreds of
  // triangles.
  const bool share = runs.size() <= 16 + n / 256;
  if (!share) {
    for (std::size_t t = 0; t < n; ++t) {
      const unsigned g = alpha[t] ? kAlphaGeometry : kPlainGeometry;
      im.indices[g].push_back(mesh.triangles[t]);
      im.triangle_of[g].push_back(static_cast<std::uint32_t>(t));
    }
  }
  if (!mesh.triangles.empty()) {
    // Embree reads the last vertex with a 16-byte load, so the vertex buffer needs 4 bytes of
    // readable memory after it. The glTF loader leaves that room in the vector's capacity; a mesh
    // built some other way is copied into a padded buffer instead.
    const void* vertices = mesh.positions.data();
    if (mesh.positions.capacity() <= mesh.positions.size()) {
      im.padded_positions.assign(3 * mesh.positions.size() + 1, 0.0f);
      for (std::size_t i = 0; i < mesh.positions.size(); ++i)
        for (int c = 0; c < 3; ++c) im.padded_positions[3 * i + c] = mesh.positions[i][c];
      vertices = im.padded_positions.data();
    }
    if (share) {
      for (std::size_t r = 0; r < runs.size(); ++r) {
        const std::size_t end = r + 1 < runs.size() ? runs[r + 1] : n;
        im.attach(static_cast<unsigned>(r), vertices, mesh.positions.size(),
                  mesh.triangles.data() + runs[r], end - runs[r], alpha[runs[r]]);
      }
      im.run_first = std::move(runs);
    } else {
      for (unsigned g : {kPlainGeometry, kAlphaGeometry})
        if (!im.indices[g].empty())
          im.attach(g, vertices, mesh.positions.size(), im.indices[g].data(),
                    im.indices[g].size(), g == kAlphaGeometry);
    }
    im.check("setting up the triangle geometry");
  }
  rtcCommitScene(im.scene);
  im.check("building the BVH");
}

Accel::~Accel() = default;

Hit Accel::intersect(const Ray& ray) const {
  const Impl& im = *impl_;
  QueryContext context;
  rtcInitIntersectContext(&context.embree);
  const bool alpha = im.alpha_tested;
  if (alpha) context.ray_key = ray_key(ray);
  RTCRayHit rh;
  rh.ray.org_x = ray.origin.x;
  rh.ray.org_y = ray.origin.y;
  rh.ray.org_z = ray.origin.z;
  rh.ray.tnear = ray.tnear;
  rh.ray.dir_x = ray.direction.x;
  rh.ray.dir_y = ray.direction.y;
  rh.ray.dir_z = ray.direction.z;
  rh.ray.time = 0.0f;
  rh.ray.mask = 0xffffffffu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  // Camera rays skip the backs of single-sided triangles: trace again past each one met (a few
  // at most in real scenes; the bound only guards against pathological stacks of them). Every
  // other ray (nearly all of them) takes one trip through the loop.
  for (int attempt = 0; attempt < 256; ++attempt) {
    rh.ray.tfar = ray.tfar;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(im.scene, &context.embree, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return Hit{};
    Hit hit;
    hit.t = rh.ray.tfar;
    // Without alpha-tested triangles the mesh is one geometry, Scene::mesh.triangles itself.
    hit.triangle = alpha ? im.scene_triangle(rh.hit.geomID, rh.hit.primID) : rh.hit.primID;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
    if (!ray.cull_back_faces || !im.single_sided[hit.triangle]) return hit;
    const glm::uvec3& t = im.source->mesh.triangles[hit.triangle];
    const auto& p = im.source->mesh.positions;
    if (glm::dot(glm::cross(p[t.y] - p[t.x], p[t.z] - p[t.x]), ray.direction) <= 0.0f)
      return hit;  // the front (counter-clockwise) face
    rh.ray.tnear = std::nextafter(hit.t, std::numeric_limits<float>::infinity());
  }
  return Hit{};
}

bool Accel::occluded(const Ray& ray) const {
  if (ray.cull_back_faces) return intersect(ray).valid();  // needs the hits to cull
  QueryContext context;
  rtcInitIntersectContext(&context.embree);
  if (impl_->alpha_tested) context.ray_key = ray_key(ray);
  RTCRay r;
  r.org_x = ray.origin.x;
  r.org_y = ray.origin.y;
  r.org_z = ray.origin.z;
  r.tnear = ray.tnear;
  r.dir_x = ray.direction.x;
  r.dir_y = ray.direction.y;
  r.dir_z = ray.direction.z;
  r.time = 0.0f;
  r.tfar = ray.tfar;
  r.mask = 0xffffffffu;
  r.id = 0;
  r.flags = 0;
  rtcOccluded1(impl_->scene, &context.embree, &r);
  return r.tfar == -std::numeric_limits<float>::infinity();  // Embree's "blocked" mark
}

}  // namespace dofcache::scene
