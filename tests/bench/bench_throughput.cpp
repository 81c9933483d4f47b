// Whole-render throughput next to the raw Embree ray rate of the same scene, in one run.
//
//   bench_throughput [--res N] [--spp N] [--threads N] [--reps N] [--packets] SCENE...
//
// For each scene: (1) renders it with the path tracer on the tile scheduler and reports Mrays/s
// and samples/s; (2) traces the same number of incoherent rays with raw Embree calls
// (rtcIntersect1 / rtcOccluded1 on the scene's own BVH, camera rays then cosine bounces off the
// geometric normal with one shadow ray per bounce, nothing else) on the same threads; prints
// both rates and their ratio. Also prints film bytes per pixel. Repeats are interleaved
// (render, raw, render, raw, ...) and the best of each is reported, so machine noise hits both.
// --packets also traces the raw rays as 8-wide packets (8 paths of a pixel in lockstep,
// rtcIntersect8 / rtcOccluded8) and prints that rate next to the single-ray one.
#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "renderer/app/render.h"
#include "renderer/scene/scene.h"
#include "sampling/film.h"
#include "sampling/sequence.h"
#include "sampling/warp.h"

using namespace tessera;

namespace {

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

/// What both raw tracers share: the scene's BVH, a fixed shadow-ray target near the top of the
/// scene, and a ray-origin offset.
struct RawScene {
    RTCScene rtc;
    Vec3f light_target;
    float eps;
};

/// Runs `pixel(raw, ctx, x, y)` (which returns the rays it traced) over every pixel, rows in
/// parallel on `threads` threads, and returns the total.
template <class PixelFn>
uint64_t raw_rows(const Scene &scene, uint32_t threads, PixelFn pixel) {
    Vec3f bmin = scene.geometry->bounds_min(), bmax = scene.geometry->bounds_max();
    const RawScene raw{scene.geometry->rtc_scene(),
                       (bmin + bmax) * 0.5f + Vec3f(0, 0.45f * (bmax.y - bmin.y), 0),
                       1e-5f * length(bmax - bmin)};
    const int w = scene.settings.width, h = scene.settings.height;
    std::atomic<uint64_t> total{0};
    tbb::task_arena arena(threads ? int(threads) : tbb::task_arena::automatic);
    arena.execute([&] {
        tbb::parallel_for(tbb::blocked_range<int>(0, h, 1), [&](const tbb::blocked_range<int> &r) {
            uint64_t rays = 0;
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            for (int y = r.begin(); y < r.end(); ++y)
                for (int x = 0; x < w; ++x) rays += pixel(raw, ctx, x, y);
            total += rays;
        });
    });
    return total.load();
}

/// Raw Embree: `bounces` closest-hit rays and as many shadow rays per camera sample.
uint64_t raw_embree(const Scene &scene, int spp, int bounces, uint32_t threads) {
    return raw_rows(scene, threads, [&](const RawScene &raw, RTCIntersectContext &ctx, int x,
                                        int y) {
        uint64_t rays = 0;
        for (int s = 0; s < spp; ++s) {
            sampling::SobolSampler smp(1);
            smp.start_pixel_sample(uint32_t(x), uint32_t(y), uint32_t(s));
            Vec2f u = smp.get_pixel_2d();
            CameraRay cr =
                scene.camera->generate_ray({x + u.x, y + u.y}, {0.5f, 0.5f}, false);
            Vec3f o = cr.ray.o, d = cr.ray.d;
            for (int b = 0; b < bounces; ++b) {
                RTCRayHit rh;
                rh.ray.org_x = o.x; rh.ray.org_y = o.y; rh.ray.org_z = o.z;
                rh.ray.dir_x = d.x; rh.ray.dir_y = d.y; rh.ray.dir_z = d.z;
                rh.ray.tnear = 0.f;
                rh.ray.tfar = kInfinity;
                rh.ray.mask = 0xFFFFFFFFu;
                rh.ray.flags = 0;
                rh.ray.time = 0.f;
                rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(raw.rtc, &ctx, &rh);
                ++rays;
                if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
                Vec3f n = normalize(Vec3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
                if (dot(n, d) > 0) n = -n;
                Vec3f p = o + d * rh.ray.tfar + n * raw.eps;
                // One shadow ray toward a fixed point near the top of the scene.
                RTCRay sr;
                Vec3f to = raw.light_target - p;
                sr.org_x = p.x; sr.org_y = p.y; sr.org_z = p.z;
                sr.dir_x = to.x; sr.dir_y = to.y; sr.dir_z = to.z;
                sr.tnear = 0.f;
                sr.tfar = 0.999f;
                sr.mask = 0xFFFFFFFFu;
                sr.flags = 0;
                sr.time = 0.f;
                rtcOccluded1(raw.rtc, &ctx, &sr);
                ++rays;
                Vec3f local = sampling::square_to_cosine_hemisphere(smp.get_2d());
                d = Frame::from_z(n).to_world(local);
                o = p;
            }
        }
        return rays;
    });
}

/// raw_embree() with the paths of a pixel's consecutive samples traced 8 at a time in lockstep:
/// every bounce's closest-hit rays as one rtcIntersect8, its shadow rays as one rtcOccluded8.
uint64_t raw_embree_packets(const Scene &scene, int spp, int bounces, uint32_t threads) {
    return raw_rows(scene, threads, [&](const RawScene &raw, RTCIntersectContext &ctx, int x,
                                        int y) {
        uint64_t rays = 0;
        for (int s0 = 0; s0 < spp; s0 += 8) {
            const int n = std::min(8, spp - s0);
            sampling::SobolSampler smp[8];
            Vec3f o[8], d[8];
            alignas(32) int valid[8];
            for (int i = 0; i < 8; ++i) {
                valid[i] = i < n ? -1 : 0;
                if (i >= n) continue;
                smp[i] = sampling::SobolSampler(1);
                smp[i].start_pixel_sample(uint32_t(x), uint32_t(y), uint32_t(s0 + i));
                Vec2f u = smp[i].get_pixel_2d();
                CameraRay cr = scene.camera->generate_ray({x + u.x, y + u.y},
                                                          {0.5f, 0.5f}, false);
                o[i] = cr.ray.o;
                d[i] = cr.ray.d;
            }
            for (int b = 0; b < bounces; ++b) {
                alignas(32) RTCRayHit8 rh;
                int active = 0;
                for (int i = 0; i < 8; ++i) {
                    rh.ray.org_x[i] = o[i].x; rh.ray.org_y[i] = o[i].y;
                    rh.ray.org_z[i] = o[i].z;
                    rh.ray.dir_x[i] = d[i].x; rh.ray.dir_y[i] = d[i].y;
                    rh.ray.dir_z[i] = d[i].z;
                    rh.ray.tnear[i] = 0.f;
                    rh.ray.tfar[i] = kInfinity;
                    rh.ray.mask[i] = 0xFFFFFFFFu;
                    rh.ray.flags[i] = 0;
                    rh.ray.time[i] = 0.f;
                    rh.ray.id[i] = unsigned(i);
                    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
                    active += valid[i] != 0;
                }
                if (!active) break;
                rtcIntersect8(valid, raw.rtc, &ctx, &rh);
                rays += uint64_t(active);
                alignas(32) RTCRay8 sr;
                Vec3f nrm[8];
                for (int i = 0; i < 8; ++i) {
                    sr.tnear[i] = 0.f;
                    sr.tfar[i] = 0.999f;
                    sr.mask[i] = 0xFFFFFFFFu;
                    sr.flags[i] = 0;
                    sr.time[i] = 0.f;
                    sr.id[i] = unsigned(i);
                    if (!valid[i]) {
                        sr.org_x[i] = sr.org_y[i] = sr.org_z[i] = 0.f;
                        sr.dir_x[i] = sr.dir_y[i] = sr.dir_z[i] = 1.f;
                        continue;
                    }
                    if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
                        valid[i] = 0;
                        sr.org_x[i] = sr.org_y[i] = sr.org_z[i] = 0.f;
                        sr.dir_x[i] = sr.dir_y[i] = sr.dir_z[i] = 1.f;
                        continue;
                    }
                    Vec3f nn = normalize(
                        Vec3f(rh.hit.Ng_x[i], rh.hit.Ng_y[i], rh.hit.Ng_z[i]));
                    if (dot(nn, d[i]) > 0) nn = -nn;
                    nrm[i] = nn;
                    o[i] = o[i] + d[i] * rh.ray.tfar[i] + nn * raw.eps;
                    Vec3f to = raw.light_target - o[i];
                    sr.org_x[i] = o[i].x; sr.org_y[i] = o[i].y; sr.org_z[i] = o[i].z;
                    sr.dir_x[i] = to.x; sr.dir_y[i] = to.y; sr.dir_z[i] = to.z;
                }
                int shadows = 0;
                for (int i = 0; i < 8; ++i) shadows += valid[i] != 0;
                if (!shadows) break;
                rtcOccluded8(valid, raw.rtc, &ctx, &sr);
                rays += uint64_t(shadows);
                for (int i = 0; i < 8; ++i) {
                    if (!valid[i]) continue;
                    Vec3f local =
                        sampling::square_to_cosine_hemisphere(smp[i].get_2d());
                    d[i] = Frame::from_z(nrm[i]).to_world(local);
                }
            }
        }
        return rays;
    });
}

}  // namespace

int main(int argc, char **argv) {
    int res = 256, spp = 16, reps = 3;
    bool packets = false, usage = false;
    uint32_t threads = 0;
    std::vector<std::string> scenes;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto next = [&] { return i + 1 < argc ? std::atoi(argv[++i]) : 0; };
        if (a == "--res") res = next();
        else if (a == "--spp") spp = next();
        else if (a == "--threads") threads = uint32_t(next());
        else if (a == "--reps") reps = next();
        else if (a == "--packets") packets = true;
        else if (a.starts_with("-")) usage = true;  // --help, or an unknown option
        else scenes.push_back(a);
    }
    if (usage || scenes.empty()) {
        std::fprintf(stderr, "usage: bench_throughput [--res N] [--spp N] [--threads N] "
                             "[--reps N] [--packets] SCENE...\n");
        return 2;
    }
    std::printf("%-28s %10s %12s %12s %12s %8s\n", "scene", "rays/smp", "Msamples/s",
                "Mrays/s", "raw Mrays/s", "ratio");
    for (const std::string &path : scenes) {
        SceneOverrides ov;
        ov.width = ov.height = res;
        ov.spp = spp;
        std::unique_ptr<Scene> scene;
        try {
            scene = load_scene(path, ov);
        } catch (const SceneError &e) {
            std::fprintf(stderr, "bench_throughput: %s\n", e.what());
            return 2;
        }
        double best_render = 1e30, best_raw = 1e30, best_packet = 1e30;
        uint64_t packet_rays = 0;
        uint64_t rays = 0, samples = 0, raw_rays = 0;
        for (int r = 0; r < reps; ++r) {
            sampling::Film film{uint32_t(res), uint32_t(res)};
            sched::AdaptiveStats st = render_scene(*scene, film, threads, 0.0, true, nullptr);
            rays = st.rays;
            samples = st.samples;
            best_render = std::min(best_render, st.wall_s);
            int bounces = std::max(1, int(double(rays) / double(samples) / 2.0 + 0.5));
            double t0 = now_s();
            raw_rays = raw_embree(*scene, spp, bounces, threads);
            best_raw = std::min(best_raw, now_s() - t0);
            if (packets) {
                t0 = now_s();
                packet_rays = raw_embree_packets(*scene, spp, bounces, threads);
                best_packet = std::min(best_packet, now_s() - t0);
            }
        }
        double mrays = double(rays) / best_render * 1e-6;
        double raw_mrays = double(raw_rays) / best_raw * 1e-6;
        std::string name = path.size() > 28 ? "..." + path.substr(path.size() - 25) : path;
        std::printf("%-28s %10.2f %12.3f %12.2f %12.2f %8.2f\n", name.c_str(),
                    double(rays) / double(samples), double(samples) / best_render * 1e-6, mrays,
                    raw_mrays, mrays / raw_mrays);
        if (packets)
            std::printf("%-28s raw 8-wide packets: %.2f Mrays/s (%.2fx single rays)\n", "",
                        double(packet_rays) / best_packet * 1e-6,
                        double(packet_rays) / best_packet * 1e-6 / raw_mrays);
    }
    std::printf("film: %zu bytes per pixel (no AOVs; %zu with all)\n",
                sampling::Film::bytes_per_pixel_for({}),
                sampling::Film::bytes_per_pixel_for(sampling::AovSet::all()));
    return 0;
}
