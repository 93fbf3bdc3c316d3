// smallpt.cpp: the lecture's smallpt path tracer as a stand-alone C++17 program.
//
// It renders the project's built-in `smallpt` scene (pathtracer/data/scenes/smallpt.xml),
// described here in code, and writes the per-pixel mean radiance as a PFM image. It is
// the example of an external renderer that `mitsuba-refs check` judges against Mitsuba 3,
// so everything that decides the expected image follows Mitsuba's conventions:
//
//   * camera: Mitsuba's `perspective` sensor (look-at frame whose camera +x is the
//     image's LEFT, vertical field of view, rays start on the near-clip plane),
//     pixel (0, 0) at the top left, samples uniform over the pixel, box filter;
//   * materials: Mitsuba's `diffuse`, `conductor` (a mirror) and `dielectric` (exact
//     Fresnel equations and the 1/eta^2 radiance scaling of refraction), all one-sided
//     except the glass; the area light emits from its front side only;
//   * depth: Mitsuba's max_depth (1 = only directly visible emission, 2 = direct
//     lighting, ..., -1 = unlimited); no clamping, the light is seen directly.
//
// The estimator is Kevin Beason's smallpt (the lecture's listing): Russian roulette on the
// surface colour's largest component after five bounces, and at the glass a split into
// reflection and refraction while the path is short, one of the two afterwards.
//
// Build:  c++ -O2 -std=c++17 -o smallpt smallpt.cpp      (add -pthread on older systems)
// Usage:  smallpt --width W --height H --spp N --seed S --out FILE.pfm
//                 [--max-depth D] [--variance FILE.pfm] [--bug NAME] [--threads T]

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <variant>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------
// Vectors and colours
// ---------------------------------------------------------------------------------------

struct Vec3 {
    double x = 0, y = 0, z = 0;
};

Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
Vec3 operator*(double s, Vec3 a) { return a * s; }
Vec3 operator/(Vec3 a, double s) { return {a.x / s, a.y / s, a.z / s}; }
Vec3& operator+=(Vec3& a, Vec3 b) { return a = a + b; }

double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec3 cross(Vec3 a, Vec3 b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double length(Vec3 a) { return std::sqrt(dot(a, a)); }
Vec3 normalize(Vec3 a) { return a / length(a); }

// An RGB triple of radiance, throughput or reflectance: multiplied channel by channel.
using Color = Vec3;
Color operator*(Color a, Color b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
double max_component(Color c) { return std::max({c.x, c.y, c.z}); }

// ---------------------------------------------------------------------------------------
// Random numbers
// ---------------------------------------------------------------------------------------

// splitmix64 (Steele, Lea and Flood 2014): a bijective 64-bit mixer, used to turn
// (seed, pixel) into a generator state that shares no structure with its neighbours'.
std::uint64_t splitmix64(std::uint64_t& state) {
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// xoshiro256** (Blackman and Vigna 2018). Every pixel owns one generator, seeded from the
// render's seed and the pixel's index: the image depends neither on the number of threads
// nor on the order in which they take pixels, and different seeds give independent images.
class Rng {
public:
    Rng(std::uint64_t seed, std::uint64_t pixel) {
        std::uint64_t key = seed;
        std::uint64_t mixed = splitmix64(key) ^ pixel;   // a different start for every pixel
        for (std::uint64_t& word : s_) word = splitmix64(mixed);
    }

    // Uniform in [0, 1): the top 53 bits as a double's mantissa.
    double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

private:
    static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

    std::uint64_t next() {
        const std::uint64_t result = rotl(s_[1] * 5, 7) * 9;
        const std::uint64_t t = s_[1] << 17;
        s_[2] ^= s_[0];
        s_[3] ^= s_[1];
        s_[1] ^= s_[2];
        s_[0] ^= s_[3];
        s_[2] ^= t;
        s_[3] = rotl(s_[3], 45);
        return result;
    }

    std::uint64_t s_[4];
};

// ---------------------------------------------------------------------------------------
// Rays, shapes and intersections
// ---------------------------------------------------------------------------------------

constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct Ray {
    Vec3 o;                  // origin
    Vec3 d;                  // unit direction
    double tmax = kInfinity; // the ray ends there (the camera's far clip)
};

struct Sphere {
    Vec3 centre;
    double radius;
};

// A rectangle: the points centre + a u + b v with |a| <= half_u, |b| <= half_v (u, v unit).
struct Rectangle {
    Vec3 centre, normal, u, v;
    double half_u, half_v;
};

struct Disk {
    Vec3 centre, normal;
    double radius;
};

using Shape = std::variant<Sphere, Rectangle, Disk>;

// Ray parameters below this are the ray's own origin; spawn_ray() moves origins off their
// surface by far more, so this only rejects t = 0 itself.
constexpr double kTMin = 1e-12;

// The nearest t in (kTMin, tmax) where the ray meets the shape, or nothing.
std::optional<double> intersect(const Sphere& s, const Ray& ray) {
    // |o + t d - c|^2 = r^2 with |d| = 1:  t^2 - 2 b t + c = 0,  b = (c - o).d
    const Vec3 oc = s.centre - ray.o;
    const double b = dot(oc, ray.d);
    const double disc = b * b - dot(oc, oc) + s.radius * s.radius;
    if (disc < 0) return std::nullopt;
    const double root = std::sqrt(disc);
    for (double t : {b - root, b + root})   // near root first; the far one from inside
        if (t > kTMin && t < ray.tmax) return t;
    return std::nullopt;
}

// The t where the ray crosses the plane through `centre` with normal `normal`.
std::optional<double> intersect_plane(Vec3 centre, Vec3 normal, const Ray& ray) {
    const double denom = dot(normal, ray.d);
    if (denom == 0) return std::nullopt;   // parallel to the plane
    const double t = dot(centre - ray.o, normal) / denom;
    if (!(t > kTMin && t < ray.tmax)) return std::nullopt;
    return t;
}

std::optional<double> intersect(const Rectangle& r, const Ray& ray) {
    const auto t = intersect_plane(r.centre, r.normal, ray);
    if (!t) return std::nullopt;
    const Vec3 local = ray.o + *t * ray.d - r.centre;
    if (std::abs(dot(local, r.u)) > r.half_u || std::abs(dot(local, r.v)) > r.half_v)
        return std::nullopt;
    return t;
}

std::optional<double> intersect(const Disk& disk, const Ray& ray) {
    const auto t = intersect_plane(disk.centre, disk.normal, ray);
    if (!t) return std::nullopt;
    const Vec3 local = ray.o + *t * ray.d - disk.centre;
    if (dot(local, local) > disk.radius * disk.radius) return std::nullopt;
    return t;
}

// The geometric normal at a point of the shape. Spheres: outwards; planar shapes: the side
// they face (Mitsuba's rectangle and disk face their local +z; both are hit from either side).
Vec3 normal_at(const Sphere& s, Vec3 p) { return (p - s.centre) / s.radius; }
Vec3 normal_at(const Rectangle& r, Vec3) { return r.normal; }
Vec3 normal_at(const Disk& d, Vec3) { return d.normal; }

// ---------------------------------------------------------------------------------------
// Materials
// ---------------------------------------------------------------------------------------

enum class Kind { Diffuse, Mirror, Glass };

struct Material {
    Kind kind;
    Color colour;              // smallpt's obj.c: diffuse reflectance / specular reflectance
    Color transmittance{};     // glass only: Mitsuba's specular_transmittance
    double ior = 1;            // glass only: interior index over exterior (air) index
    Color emission{};          // radiance leaving the front side (area lights)
};

Material diffuse(Color reflectance) { return {Kind::Diffuse, reflectance}; }
Material mirror(Color specular_reflectance) { return {Kind::Mirror, specular_reflectance}; }
Material glass(double ior, Color specular_reflectance, Color specular_transmittance) {
    return {Kind::Glass, specular_reflectance, specular_transmittance, ior};
}
Material light(Color radiance) {   // a black surface that emits
    Material m = diffuse({0, 0, 0});
    m.emission = radiance;
    return m;
}

// ---------------------------------------------------------------------------------------
// The scene
// ---------------------------------------------------------------------------------------

struct Object {
    Shape shape;
    Material material;
};

struct Hit {
    double t;
    Vec3 p;        // the point hit
    Vec3 n;        // geometric (= shading) normal, unit
    const Material* material;
};

struct Scene {
    std::vector<Object> objects;

    // The nearest surface along the ray (a linear search: the scene has nine objects).
    std::optional<Hit> intersect(const Ray& ray) const {
        std::optional<Hit> nearest;
        Ray shortened = ray;
        for (const Object& object : objects) {
            const auto t = std::visit([&](const auto& s) { return ::intersect(s, shortened); },
                                      object.shape);
            if (!t) continue;
            shortened.tmax = *t;
            const Vec3 p = ray.o + *t * ray.d;
            const Vec3 n = std::visit([&](const auto& s) { return normal_at(s, p); }, object.shape);
            nearest = Hit{*t, p, n, &object.material};
        }
        return nearest;
    }
};

// A rectangle from its centre, normal and the half extents along two unit edge directions.
Rectangle rectangle(Vec3 centre, Vec3 normal, Vec3 u, double half_u, Vec3 v, double half_v) {
    return {centre, normal, u, v, half_u, half_v};
}

// smallpt.xml, object by object. The room is the box x in [1, 99], y in [0, 81.6],
// z in [0, 170]; each wall is a rectangle facing into the room (smallpt's walls are spheres
// of radius 1e5, which the XML replaces by the planes they touch). The light is the disk
// that smallpt's radius-600 light sphere shows to the room: radius 18, 0.05 below the
// ceiling, facing down.
Scene smallpt_scene() {
    const Vec3 X{1, 0, 0}, Y{0, 1, 0}, Z{0, 0, 1};
    const Material red = diffuse({0.75, 0.25, 0.25});
    const Material blue = diffuse({0.25, 0.25, 0.75});
    const Material grey = diffuse({0.75, 0.75, 0.75});
    const Material black = diffuse({0, 0, 0});
    const Color almost_white{0.999, 0.999, 0.999};

    Scene scene;
    auto add = [&](Shape shape, Material material) { scene.objects.push_back({shape, material}); };
    add(rectangle({1, 40.8, 85}, X, Y, 40.8, Z, 85), red);        // left wall, x = 1
    add(rectangle({99, 40.8, 85}, -X, Y, 40.8, Z, 85), blue);     // right wall, x = 99
    add(rectangle({50, 40.8, 0}, Z, X, 49, Y, 40.8), grey);       // back wall, z = 0
    add(rectangle({50, 40.8, 170}, -Z, X, 49, Y, 40.8), black);   // front wall, z = 170
    add(rectangle({50, 0, 85}, Y, X, 49, Z, 85), grey);           // floor, y = 0
    add(rectangle({50, 81.6, 85}, -Y, X, 49, Z, 85), grey);       // ceiling, y = 81.6
    add(Sphere{{27, 16.5, 47}, 16.5}, mirror(almost_white));
    add(Sphere{{73, 16.5, 78}, 16.5}, glass(1.5, almost_white, almost_white));
    add(Disk{{50, 81.55, 81.6}, -Y, 18.0}, light({12, 12, 12}));
    return scene;
}

// ---------------------------------------------------------------------------------------
// The camera: Mitsuba's perspective sensor
// ---------------------------------------------------------------------------------------

struct Camera {
    Vec3 origin;
    Vec3 left, up, forward;   // Mitsuba's look-at frame: camera +x points to the image's left
    double tan_half_fov_y;
    double aspect;            // width / height
    double near_clip, far_clip;
    int width, height;

    // The ray through film position (column + u, row + v), row 0 at the top of the image.
    Ray generate_ray(int column, int row, double u, double v) const {
        const double sx = (column + u) / width, sy = (row + v) / height;
        // On the plane z = 1 of camera space; x grows to the left, y upwards.
        const Vec3 d_camera = normalize({(1 - 2 * sx) * tan_half_fov_y * aspect,
                                         (1 - 2 * sy) * tan_half_fov_y, 1.0});
        const Vec3 d = normalize(d_camera.x * left + d_camera.y * up + d_camera.z * forward);
        // The clip distances are along the optical axis, not along the ray.
        const double t_near = near_clip / d_camera.z, t_far = far_clip / d_camera.z;
        return {origin + t_near * d, d, t_far - t_near};
    }
};

// <lookat origin="50, 52, 295.6" target="50, 51.957388, 294.6" up="0, 1, 0"/>, fov 28.799316
// on the y axis, near_clip 140 (rays start inside the room, past its black front wall).
Camera smallpt_camera(int width, int height) {
    const Vec3 origin{50, 52, 295.6}, target{50, 51.957388, 294.6}, up{0, 1, 0};
    const Vec3 forward = normalize(target - origin);
    const Vec3 left = normalize(cross(up, forward));   // Mitsuba's Transform::look_at
    const Vec3 true_up = cross(forward, left);
    const double fov_y = 28.799316 * kPi / 180;
    return {origin, left, true_up, forward, std::tan(fov_y / 2),
            static_cast<double>(width) / height, 140.0, 10000.0, width, height};
}

// ---------------------------------------------------------------------------------------
// Scattering
// ---------------------------------------------------------------------------------------

// A ray leaving surface point p along wo, moved off the surface to wo's side of it so that
// it does not hit the surface it starts on (Mitsuba's offset_p, scaled for doubles).
Ray spawn_ray(const Hit& hit, Vec3 wo) {
    const double scale = 1 + std::max({std::abs(hit.p.x), std::abs(hit.p.y), std::abs(hit.p.z)});
    const double offset = dot(hit.n, wo) >= 0 ? 1e-9 * scale : -1e-9 * scale;
    return {hit.p + offset * hit.n, wo};
}

// Two unit vectors that make (s, t, n) an orthonormal frame (Duff et al. 2017).
void tangent_frame(Vec3 n, Vec3& s, Vec3& t) {
    const double sign = std::copysign(1.0, n.z);
    const double a = -1 / (sign + n.z);
    const double b = n.x * n.y * a;
    s = {1 + sign * n.x * n.x * a, sign * b, -sign * n.x};
    t = {b, sign + n.y * n.y * a, -n.y};
}

// A direction about n with density cos(theta) / pi: a uniform point of the unit disk lifted
// onto the hemisphere (Malley). The diffuse BRDF's rho / pi * cos / pdf is then rho.
Vec3 sample_cosine_hemisphere(Vec3 n, Rng& rng) {
    const double r = std::sqrt(rng.uniform()), phi = 2 * kPi * rng.uniform();
    const double x = r * std::cos(phi), y = r * std::sin(phi);
    const double z = std::sqrt(std::max(0.0, 1 - x * x - y * y));
    Vec3 s, t;
    tangent_frame(n, s, t);
    return x * s + y * t + z * n;
}

Vec3 reflect(Vec3 wi, Vec3 n) { return 2 * dot(wi, n) * n - wi; }

// The glass's two Dirac lobes at one hit, as Mitsuba's dielectric defines them.
struct GlassLobes {
    double F;                  // Fresnel reflectance (smallpt's Re; Tr = 1 - F)
    Vec3 wo_r, wo_t;           // reflected and refracted directions
    Color weight_r, weight_t;  // F R_s and (1 - F) T_s / eta^2 (0 under total reflection)
};

// wi points away from the surface (back along the incoming ray); n is the outward normal.
GlassLobes glass_lobes(const Material& m, Vec3 n, Vec3 wi) {
    const double cos_i = dot(wi, n);
    // eta_it: index ratio across the interface in the direction of travel.
    const double eta_it = cos_i >= 0 ? m.ior : 1 / m.ior, eta_ti = 1 / eta_it;
    const double cos2_t = 1 - eta_ti * eta_ti * (1 - cos_i * cos_i);
    const double c_i = std::abs(cos_i), c_t = std::sqrt(std::max(cos2_t, 0.0));

    // The exact Fresnel equations for unpolarized light (not Schlick's approximation):
    // Mitsuba's dielectric uses them, and the expected image has to be Mitsuba's.
    // Under total internal reflection c_t = 0 and F = 1.
    double F = 1;
    if (c_i > 0) {
        const double r_s = (c_i - eta_it * c_t) / (c_i + eta_it * c_t);
        const double r_p = (c_t - eta_it * c_i) / (c_t + eta_it * c_i);
        F = 0.5 * (r_s * r_s + r_p * r_p);
    }
    // Snell: the tangential part scales by eta_ti, the normal part crosses to the other side.
    const double cos_t = cos_i >= 0 ? -c_t : c_t;
    const Vec3 wo_t = -eta_ti * wi + (eta_ti * cos_i + cos_t) * n;
    // Radiance is squeezed into a smaller solid angle when it enters the denser medium:
    // a camera path entering the glass carries 1/eta^2 of it, one leaving carries eta^2
    // (Mitsuba's TransportMode::Radiance).
    const Color weight_t = cos2_t > 0 ? ((1 - F) * eta_ti * eta_ti) * m.transmittance : Color{};
    return {F, reflect(wi, n), wo_t, F * m.colour, weight_t};
}

// ---------------------------------------------------------------------------------------
// The estimator
// ---------------------------------------------------------------------------------------

enum class Bug { None, Roulette, FresnelSplit };

struct Settings {
    int width = 0, height = 0, spp = 0;
    std::uint64_t seed = 0;
    int max_depth = -1;
    Bug bug = Bug::None;
    int threads = 1;
    std::string out, variance_out;
};

// smallpt's constants: Russian roulette once depth > 5, glass splitting while depth <= 2.
constexpr int kRouletteDepth = 5;
constexpr int kSplitDepth = 2;
// max_depth = -1 still stops after this many segments, as the project's tracer does, so
// that the two estimators are the same; roulette ends real paths long before.
constexpr int kMaxSegments = 1000;

Color emitted(const Hit& hit, Vec3 wi) {
    return dot(hit.n, wi) > 0 ? hit.material->emission : Color{};   // one-sided area light
}

// Radiance arriving at the ray's origin along -ray.d. `depth` counts the path's segments
// before this ray: 0 for a camera ray. Iterative except at the glass split, where the two
// branches are estimated by recursive calls (at most kSplitDepth deep).
Color radiance(const Scene& scene, Ray ray, int depth, Rng& rng, const Settings& settings) {
    const int depth_limit = settings.max_depth < 0 ? kMaxSegments : settings.max_depth;
    Color L{0, 0, 0};     // radiance gathered so far
    Color beta{1, 1, 1};  // throughput: the product of BSDF * cos / pdf (and 1 / p) so far
    if (depth >= depth_limit) return L;   // max_depth 0: no segment at all
    for (;;) {
        const std::optional<Hit> hit = scene.intersect(ray);
        if (!hit) return L;   // escaped: the scene has no environment light
        ++depth;              // smallpt's ++depth: the segments that reached this hit
        const Material& m = *hit->material;
        const Vec3 wi = -ray.d;
        L += beta * emitted(*hit, wi);   // obj.e, seen directly (hide_emitters is false)
        if (depth >= depth_limit) return L;

        // Russian roulette: continue with probability p = max(f), dividing by p keeps the
        // estimate unbiased (the `roulette` bug forgets the division).
        if (depth > kRouletteDepth) {
            const double p = max_component(m.colour);
            if (!(rng.uniform() < p)) return L;
            if (settings.bug != Bug::Roulette) beta = beta / p;
        }

        Vec3 wo;
        switch (m.kind) {
        case Kind::Diffuse:
            if (dot(wi, hit->n) <= 0) return L;   // one-sided: black from behind
            wo = sample_cosine_hemisphere(hit->n, rng);
            beta = beta * m.colour;
            break;
        case Kind::Mirror:
            if (dot(wi, hit->n) <= 0) return L;
            wo = reflect(wi, hit->n);
            beta = beta * m.colour;   // a perfect conductor: Fresnel reflectance 1
            break;
        case Kind::Glass: {
            const GlassLobes g = glass_lobes(m, hit->n, wi);
            if (depth <= kSplitDepth) {
                // Short paths follow both lobes: radiance(refl) Re + radiance(refr) Tr.
                Color split = g.weight_r * radiance(scene, spawn_ray(*hit, g.wo_r), depth, rng, settings);
                if (max_component(g.weight_t) > 0)
                    split += g.weight_t * radiance(scene, spawn_ray(*hit, g.wo_t), depth, rng, settings);
                return L + beta * split;
            }
            // Longer paths follow one lobe: reflection with probability P = .25 + .5 Re,
            // weighted by Re / P, else refraction weighted by Tr / (1 - P). The
            // `fresnel-split` bug keeps the weights Re and Tr of the split above.
            const double P = 0.25 + 0.5 * g.F;
            const bool fresnel_bug = settings.bug == Bug::FresnelSplit;
            if (rng.uniform() < P) {
                wo = g.wo_r;
                beta = beta * (fresnel_bug ? g.weight_r : g.weight_r / P);
            } else {
                wo = g.wo_t;
                beta = beta * (fresnel_bug ? g.weight_t : g.weight_t / (1 - P));
            }
            break;
        }
        }
        if (max_component(beta) <= 0) return L;   // carries no light (black surface, TIR)
        ray = spawn_ray(*hit, wo);
    }
}

// ---------------------------------------------------------------------------------------
// The film: per-pixel mean and per-sample variance
// ---------------------------------------------------------------------------------------

// Welford's running mean and sum of squared deviations, one channel at a time: stable
// where the mean is large against the spread.
struct PixelStats {
    Color mean{}, m2{};
    long n = 0;

    void add(Color x) {
        ++n;
        const Color delta = x - mean;
        mean += delta / static_cast<double>(n);
        m2 += delta * (x - mean);
    }
    // The unbiased per-sample variance: sum of squared deviations / (n - 1).
    Color variance() const { return n > 1 ? m2 / static_cast<double>(n - 1) : Color{}; }
};

struct Film {
    int width, height;
    std::vector<PixelStats> pixels;   // row-major, row 0 at the top
};

void render_pixel(const Scene& scene, const Camera& camera, const Settings& settings,
                  int column, int row, PixelStats& stats) {
    const std::uint64_t index = static_cast<std::uint64_t>(row) * settings.width + column;
    Rng rng(settings.seed, index);
    for (int sample = 0; sample < settings.spp; ++sample) {
        const double u = rng.uniform(), v = rng.uniform();   // uniform over the pixel: box filter
        const Ray ray = camera.generate_ray(column, row, u, v);
        stats.add(radiance(scene, ray, 0, rng, settings));
    }
}

Film render(const Scene& scene, const Camera& camera, const Settings& settings) {
    Film film{settings.width, settings.height,
              std::vector<PixelStats>(static_cast<size_t>(settings.width) * settings.height)};
    std::atomic<int> next_row{0};
    auto work = [&] {   // threads take whole rows; each pixel has its own generator
        for (int row; (row = next_row++) < settings.height;)
            for (int column = 0; column < settings.width; ++column)
                render_pixel(scene, camera, settings, column, row,
                             film.pixels[static_cast<size_t>(row) * settings.width + column]);
    };
    std::vector<std::thread> workers;
    for (int i = 1; i < settings.threads; ++i) workers.emplace_back(work);
    work();
    for (std::thread& worker : workers) worker.join();
    return film;
}

// ---------------------------------------------------------------------------------------
// PFM output
// ---------------------------------------------------------------------------------------

void put_float_le(std::string& bytes, float value) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, sizeof bits);
    for (int shift = 0; shift < 32; shift += 8) bytes.push_back(static_cast<char>(bits >> shift));
}

// A colour PFM: "PF", the size, scale -1 (negative: little-endian), then float32 RGB rows
// from the BOTTOM of the image to the top, as the format requires.
// Returns an empty string on success, else why the file could not be written.
std::string write_pfm(const std::string& path, const Film& film, Color (*value)(const PixelStats&)) {
    std::string bytes = "PF\n" + std::to_string(film.width) + " " + std::to_string(film.height) + "\n-1.0\n";
    for (int row = film.height - 1; row >= 0; --row)
        for (int column = 0; column < film.width; ++column) {
            const Color c = value(film.pixels[static_cast<size_t>(row) * film.width + column]);
            for (double channel : {c.x, c.y, c.z}) put_float_le(bytes, static_cast<float>(channel));
        }
    errno = 0;
    std::ofstream file(path, std::ios::binary);
    file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    file.close();
    if (file) return {};
    return "cannot write " + path + ": " + (errno ? std::strerror(errno) : "write failed");
}

// ---------------------------------------------------------------------------------------
// Command line
// ---------------------------------------------------------------------------------------

const char* const kUsage =
    "usage: smallpt --width W --height H --spp N --seed S --out FILE.pfm\n"
    "               [--max-depth D] [--variance FILE.pfm] [--bug roulette|fresnel-split]\n"
    "               [--threads T]\n";

struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

// The whole of `text` as an integer in [low, high], or a UsageError naming the option.
template <typename Int>
Int parse_integer(const std::string& option, const std::string& text, Int low, Int high) {
    Int value{};
    const char* end = text.data() + text.size();
    const auto [stop, error] = std::from_chars(text.data(), end, value);
    if (error != std::errc() || stop != end || text.empty() || value < low || value > high)
        throw UsageError(option + " needs an integer in [" + std::to_string(low) + ", " +
                         std::to_string(high) + "], got '" + text + "'");
    return value;
}

Settings parse_arguments(int argc, char** argv) {
    Settings s;
    bool width = false, height = false, spp = false, seed = false;
    for (int i = 1; i < argc; ++i) {
        const std::string option = argv[i];
        if (option == "--help" || option == "-h") {
            std::cout << kUsage;
            std::exit(0);
        }
        if (i + 1 >= argc) throw UsageError(option.rfind("--", 0) == 0 ? option + " needs a value"
                                                                      : "unexpected argument '" + option + "'");
        const std::string value = argv[++i];
        constexpr int kMaxSide = 1 << 16;
        if (option == "--width") s.width = parse_integer(option, value, 1, kMaxSide), width = true;
        else if (option == "--height") s.height = parse_integer(option, value, 1, kMaxSide), height = true;
        else if (option == "--spp") s.spp = parse_integer(option, value, 1, 1 << 30), spp = true;
        else if (option == "--seed")
            s.seed = parse_integer<std::uint64_t>(option, value, 0, std::numeric_limits<std::uint64_t>::max()),
            seed = true;
        else if (option == "--max-depth") s.max_depth = parse_integer(option, value, -1, 1 << 30);
        else if (option == "--threads") s.threads = parse_integer(option, value, 1, 1024);
        else if (option == "--out") s.out = value;
        else if (option == "--variance") s.variance_out = value;
        else if (option == "--bug") {
            if (value == "roulette") s.bug = Bug::Roulette;
            else if (value == "fresnel-split") s.bug = Bug::FresnelSplit;
            else throw UsageError("unknown --bug '" + value + "' (known: roulette, fresnel-split)");
        } else {
            throw UsageError("unknown option '" + option + "'");
        }
    }
    if (!width || !height || !spp || !seed || s.out.empty())
        throw UsageError("--width, --height, --spp, --seed and --out are required");
    if (!s.variance_out.empty() && s.spp < 2)
        throw UsageError("--variance needs --spp >= 2 (a variance of one sample is undefined)");
    return s;
}

}  // namespace

int main(int argc, char** argv) {
    Settings settings;
    try {
        settings = parse_arguments(argc, argv);
    } catch (const UsageError& error) {
        std::cerr << "smallpt: " << error.what() << " (--help for usage)\n";
        return 2;
    }
    const Scene scene = smallpt_scene();
    const Camera camera = smallpt_camera(settings.width, settings.height);
    const Film film = render(scene, camera, settings);

    std::string error = write_pfm(settings.out, film, [](const PixelStats& p) { return p.mean; });
    if (error.empty() && !settings.variance_out.empty())
        error = write_pfm(settings.variance_out, film, [](const PixelStats& p) { return p.variance(); });
    if (!error.empty()) {
        std::cerr << "smallpt: " << error << "\n";
        return 1;
    }
    return 0;
}
