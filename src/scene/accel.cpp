// Embree 3: one device, one static scene, one triangle geometry over Scene::mesh.
#include "dofcache/scene/accel.h"

#include <embree3/rtcore.h>

#include <mutex>
#include <string>
#include <vector>

#include "dofcache/core/error.h"

namespace dofcache::scene {
namespace {

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
  std::vector<float> padded_positions;  // only when Scene::mesh.positions cannot be shared

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
  if (!mesh.triangles.empty()) {
    RTCGeometry geom = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
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
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, vertices, 0,
                               3 * sizeof(float), mesh.positions.size());
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                               mesh.triangles.data(), 0, 3 * sizeof(std::uint32_t),
                               mesh.triangles.size());
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(im.scene, geom, 0);
    rtcReleaseGeometry(geom);  // the scene holds it now
    im.check("setting up the triangle geometry");
  }
  rtcCommitScene(im.scene);
  im.check("building the BVH");
}

Accel::~Accel() = default;

Hit Accel::intersect(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  rh.ray.org_x = ray.origin.x;
  rh.ray.org_y = ray.origin.y;
  rh.ray.org_z = ray.origin.z;
  rh.ray.tnear = ray.tnear;
  rh.ray.dir_x = ray.direction.x;
  rh.ray.dir_y = ray.direction.y;
  rh.ray.dir_z = ray.direction.z;
  rh.ray.time = 0.0f;
  rh.ray.tfar = ray.tfar;
  rh.ray.mask = 0xffffffffu;
  rh.ray.id = 0;
  rh.ray.flags = 0;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);

  Hit hit;
  if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
    hit.t = rh.ray.tfar;
    hit.triangle = rh.hit.primID;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
  }
  return hit;
}

bool Accel::occluded(const Ray& ray) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
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
  rtcOccluded1(impl_->scene, &context, &r);
  return r.tfar == -std::numeric_limits<float>::infinity();  // Embree's "blocked" mark
}

}  // namespace dofcache::scene
