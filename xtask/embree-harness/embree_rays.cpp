// Times Embree 3 on a ray dump of `cargo xtask rays dump`, single-threaded:
// rtcIntersect1 on camera.rays and diffuse.rays, rtcOccluded1 on
// shadow.rays, and rtcIntersect8/16 packets of consecutive camera rays.
// Prints, per build quality and set, the median and best Mrays/s of N
// timed passes (after a warm-up) by the thread's CPU time, the median by
// the wall clock, the hit count and the sum of hit t, the
// figures `cargo xtask rays bench` prints for the same files.
//
// Needs Embree 3's headers and library (Debian and Ubuntu: `apt-get install
// libembree-dev`). Nothing in the workspace builds this file: neither cargo
// nor CI; docs/benchmarks.md ("Ray throughput against Embree") says how it
// was used.
//
// Build: g++ -O3 -march=native -std=c++17 embree_rays.cpp -lembree3 -o embree_rays
// Run:   [EMBREE_CONFIG=isa=sse4.2] ./embree_rays DIR [PASSES] [low|medium|high ...]

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace {

struct Ray {
  float o[3], d[3], tmax;
};

template <class T>
std::vector<T> read_file(const std::string& path, size_t record) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) {
    std::fprintf(stderr, "error: cannot read %s\n", path.c_str());
    std::exit(1);
  }
  size_t bytes = static_cast<size_t>(in.tellg());
  if (bytes % record != 0) {
    std::fprintf(stderr, "error: %s: %zu bytes is not a whole number of %zu-byte records\n",
                 path.c_str(), bytes, record);
    std::exit(1);
  }
  std::vector<T> v(bytes / sizeof(T));
  in.seekg(0);
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(bytes));
  return v;
}

struct Result {
  uint64_t hits = 0;
  double t_sum = 0.0;
  bool operator!=(const Result& r) const { return hits != r.hits || t_sum != r.t_sum; }
};

void error_handler(void*, RTCError code, const char* message) {
  std::fprintf(stderr, "embree error %d: %s\n", static_cast<int>(code), message);
  std::exit(1);
}

RTCScene build(RTCDevice device, const std::vector<float>& vertices,
               const std::vector<uint32_t>& indices, RTCBuildQuality quality, double* seconds) {
  auto start = std::chrono::steady_clock::now();
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, RTC_SCENE_FLAG_NONE);
  rtcSetSceneBuildQuality(scene, quality);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geom, quality);
  size_t nv = vertices.size() / 3, nt = indices.size() / 3;
  // Embree allocates these with the padding its SIMD loads need.
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  std::memcpy(v, vertices.data(), vertices.size() * sizeof(float));
  auto* ix = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(
      geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
  std::memcpy(ix, indices.data(), indices.size() * sizeof(uint32_t));
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return scene;
}

Result closest1(RTCScene scene, const std::vector<Ray>& rays) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  Result r;
  for (const Ray& ray : rays) {
    RTCRayHit rh;
    rh.ray.org_x = ray.o[0]; rh.ray.org_y = ray.o[1]; rh.ray.org_z = ray.o[2];
    rh.ray.dir_x = ray.d[0]; rh.ray.dir_y = ray.d[1]; rh.ray.dir_z = ray.d[2];
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = ray.tmax;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rh);
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
      r.hits++;
      r.t_sum += rh.ray.tfar;
    }
  }
  return r;
}

Result any1(RTCScene scene, const std::vector<Ray>& rays) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  Result r;
  for (const Ray& ray : rays) {
    RTCRay rr;
    rr.org_x = ray.o[0]; rr.org_y = ray.o[1]; rr.org_z = ray.o[2];
    rr.dir_x = ray.d[0]; rr.dir_y = ray.d[1]; rr.dir_z = ray.d[2];
    rr.tnear = 0.0f;
    rr.tfar = ray.tmax;
    rr.time = 0.0f;
    rr.mask = 0xFFFFFFFFu;
    rr.id = 0;
    rr.flags = 0;
    rtcOccluded1(scene, &context, &rr);
    if (rr.tfar == -std::numeric_limits<float>::infinity()) r.hits++;
  }
  return r;
}

// Packets of N consecutive rays (the dump's row-major pixel order), marked
// coherent. Hits are summed in ray order, as in the single-ray loops.
template <int N, class RayHitN, void (*Intersect)(const int*, RTCScene, RTCIntersectContext*, RayHitN*)>
Result closest_packets(RTCScene scene, const std::vector<Ray>& rays) {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  Result r;
  alignas(64) RayHitN rh;
  alignas(64) int valid[N];
  for (size_t base = 0; base < rays.size(); base += N) {
    for (int k = 0; k < N; k++) {
      size_t i = base + k;
      valid[k] = i < rays.size() ? -1 : 0;
      const Ray& ray = rays[std::min(i, rays.size() - 1)];
      rh.ray.org_x[k] = ray.o[0]; rh.ray.org_y[k] = ray.o[1]; rh.ray.org_z[k] = ray.o[2];
      rh.ray.dir_x[k] = ray.d[0]; rh.ray.dir_y[k] = ray.d[1]; rh.ray.dir_z[k] = ray.d[2];
      rh.ray.tnear[k] = 0.0f;
      rh.ray.tfar[k] = ray.tmax;
      rh.ray.time[k] = 0.0f;
      rh.ray.mask[k] = 0xFFFFFFFFu;
      rh.ray.id[k] = 0;
      rh.ray.flags[k] = 0;
      rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    Intersect(valid, scene, &context, &rh);
    for (int k = 0; k < N; k++) {
      if (valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) {
        r.hits++;
        r.t_sum += rh.ray.tfar[k];
      }
    }
  }
  return r;
}

// CPU seconds of the calling thread (leaves out time spent waiting for a
// core on a shared machine).
double thread_cpu_seconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

double median_of(std::vector<double> s) {
  std::sort(s.begin(), s.end());
  size_t m = s.size() / 2;
  return s.size() % 2 ? s[m] : 0.5 * (s[m - 1] + s[m]);
}

void time_set(const char* quality, const char* name, const char* query, size_t count,
              int passes, const std::function<Result()>& pass) {
  Result expected = pass();  // warm-up
  std::vector<double> seconds, wall;
  for (int p = 0; p < passes; p++) {
    double cpu_start = thread_cpu_seconds();
    auto start = std::chrono::steady_clock::now();
    Result r = pass();
    wall.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    seconds.push_back(thread_cpu_seconds() - cpu_start);
    if (r != expected) {
      std::fprintf(stderr, "error: %s: passes disagree\n", name);
      std::exit(1);
    }
  }
  double best = *std::min_element(seconds.begin(), seconds.end());
  std::printf("| %s | %s | %s | %zu | %.2f | %.2f | %.2f | %llu | %.6e |\n", quality, name, query,
              count, count / median_of(seconds) / 1e6, count / best / 1e6,
              count / median_of(wall) / 1e6,
              static_cast<unsigned long long>(expected.hits), expected.t_sum);
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DIR [PASSES] [low|medium|high ...]\n", argv[0]);
    return 2;
  }
  std::string dir = argv[1];
  int passes = argc > 2 ? std::atoi(argv[2]) : 9;
  if (passes <= 0) {
    std::fprintf(stderr, "error: PASSES must be a positive number\n");
    return 2;
  }
  std::vector<std::pair<std::string, RTCBuildQuality>> qualities;
  for (int a = 3; a < argc; a++) {
    std::string q = argv[a];
    if (q == "low") qualities.push_back({q, RTC_BUILD_QUALITY_LOW});
    else if (q == "medium") qualities.push_back({q, RTC_BUILD_QUALITY_MEDIUM});
    else if (q == "high") qualities.push_back({q, RTC_BUILD_QUALITY_HIGH});
    else {
      std::fprintf(stderr, "error: unknown build quality '%s' (low, medium, high)\n", q.c_str());
      return 2;
    }
  }
  if (qualities.empty()) qualities = {{"medium", RTC_BUILD_QUALITY_MEDIUM}, {"high", RTC_BUILD_QUALITY_HIGH}};

  auto vertices = read_file<float>(dir + "/mesh.vertices", 12);
  auto indices = read_file<uint32_t>(dir + "/mesh.indices", 12);
  auto camera = read_file<Ray>(dir + "/camera.rays", sizeof(Ray));
  auto diffuse = read_file<Ray>(dir + "/diffuse.rays", sizeof(Ray));
  auto shadow = read_file<Ray>(dir + "/shadow.rays", sizeof(Ray));
  for (uint32_t i : indices) {
    if (i >= vertices.size() / 3) {
      std::fprintf(stderr, "error: %s/mesh.indices: vertex %u out of range\n", dir.c_str(), i);
      return 1;
    }
  }

  // Flush-to-zero and denormals-are-zero, as Embree's documentation asks
  // of every thread that calls it.
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  // Device configuration from the environment, e.g. "isa=sse4.2" to keep
  // Embree to the instruction set the renderer is built for.
  const char* config = std::getenv("EMBREE_CONFIG");
  RTCDevice device = rtcNewDevice(config);
  rtcSetDeviceErrorFunction(device, error_handler, nullptr);
  std::printf("embree %ld [%s] on %s (%zu triangles), 1 thread, %d passes timed by thread CPU time\n\n",
              static_cast<long>(rtcGetDeviceProperty(device, RTC_DEVICE_PROPERTY_VERSION)),
              config ? config : "default config", dir.c_str(), indices.size() / 3, passes);
  std::printf("| build | rays | query | count | median Mrays/s | best Mrays/s | wall median Mrays/s | hits | sum of t |\n");
  std::printf("|---|---|---|---:|---:|---:|---:|---:|---:|\n");
  for (auto& [qname, quality] : qualities) {
    double build_s = 0.0;
    RTCScene scene = build(device, vertices, indices, quality, &build_s);
    std::string label = qname + " (" + std::to_string(build_s).substr(0, 5) + " s)";
    const char* q = label.c_str();
    time_set(q, "camera", "closest", camera.size(), passes, [&] { return closest1(scene, camera); });
    time_set(q, "camera x8", "closest", camera.size(), passes,
             [&] { return closest_packets<8, RTCRayHit8, rtcIntersect8>(scene, camera); });
    time_set(q, "camera x16", "closest", camera.size(), passes,
             [&] { return closest_packets<16, RTCRayHit16, rtcIntersect16>(scene, camera); });
    time_set(q, "diffuse", "closest", diffuse.size(), passes, [&] { return closest1(scene, diffuse); });
    time_set(q, "shadow", "any", shadow.size(), passes, [&] { return any1(scene, shadow); });
    rtcReleaseScene(scene);
  }
  rtcReleaseDevice(device);
  return 0;
}
