// Small vector maths for the renderer: Vec2, Vec3, an orthonormal Frame and a
// 4x4 affine transform. Geometry is float; the film accumulates doubles.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace vsl {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInvPi = 0.31830988618379067154f;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct Vec2 {
  float x = 0, y = 0;
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
  constexpr Vec3() = default;
  constexpr Vec3(float a, float b, float c) : x(a), y(b), z(c) {}
  constexpr explicit Vec3(float s) : x(s), y(s), z(s) {}
  float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  Vec3 operator-() const { return {-x, -y, -z}; }
  Vec3& operator+=(const Vec3& o) {
    x += o.x;
    y += o.y;
    z += o.z;
    return *this;
  }
  Vec3& operator-=(const Vec3& o) {
    x -= o.x;
    y -= o.y;
    z -= o.z;
    return *this;
  }
  Vec3& operator*=(const Vec3& o) {
    x *= o.x;
    y *= o.y;
    z *= o.z;
    return *this;
  }
  Vec3& operator*=(float s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  Vec3& operator/=(float s) { return *this *= (1.0f / s); }
};

inline Vec3 operator+(Vec3 a, const Vec3& b) { return a += b; }
inline Vec3 operator-(Vec3 a, const Vec3& b) { return a -= b; }
inline Vec3 operator*(Vec3 a, const Vec3& b) { return a *= b; }
inline Vec3 operator*(Vec3 a, float s) { return a *= s; }
inline Vec3 operator*(float s, Vec3 a) { return a *= s; }
inline Vec3 operator/(Vec3 a, float s) { return a /= s; }
inline Vec3 operator/(const Vec3& a, const Vec3& b) { return {a.x / b.x, a.y / b.y, a.z / b.z}; }
inline float dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(const Vec3& a) { return std::sqrt(dot(a, a)); }
inline float lengthSquared(const Vec3& a) { return dot(a, a); }
inline Vec3 normalize(const Vec3& a) {
  float l = length(a);
  return l > 0 ? a / l : Vec3(0.0f);
}
inline Vec3 min(const Vec3& a, const Vec3& b) { return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)}; }
inline Vec3 max(const Vec3& a, const Vec3& b) { return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)}; }
inline float maxComponent(const Vec3& a) { return std::max(a.x, std::max(a.y, a.z)); }
inline float luminance(const Vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
inline bool isFinite(const Vec3& a) { return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z); }
inline bool isBlack(const Vec3& a) { return a.x == 0 && a.y == 0 && a.z == 0; }
inline Vec3 lerp(float t, const Vec3& a, const Vec3& b) { return a * (1 - t) + b * t; }
inline Vec3 reflect(const Vec3& w, const Vec3& n) { return 2.0f * dot(w, n) * n - w; }
inline float clamp(float v, float lo, float hi) { return std::min(std::max(v, lo), hi); }
inline float safeSqrt(float v) { return std::sqrt(std::max(v, 0.0f)); }
template <typename T>
inline T sqr(T v) {
  return v * v;
}

// True when this CPU runs the AVX2 block forms (core/simd.h): AVX2 and FMA.
bool simdAvailable();

// sin and cos of t pi/4 for t in [-1, 1]: Taylor polynomials to x^9 and x^8,
// whose truncation error (below 3e-8 at pi/4) is under float's rounding. The
// samplers use these instead of libm so that their AVX2 forms (core/simd.h),
// which repeat these operations in the same order, give the same bits.
constexpr float kSinTaylor[4] = {-1.0f / 6, 1.0f / 120, -1.0f / 5040, 1.0f / 362880};
constexpr float kCosTaylor[4] = {-1.0f / 2, 1.0f / 24, -1.0f / 720, 1.0f / 40320};
inline void sinCosQuarterPi(float t, float& s, float& c) {
  const float x = t * (kPi / 4), x2 = x * x;
  s = x + x * x2 * (kSinTaylor[0] + x2 * (kSinTaylor[1] + x2 * (kSinTaylor[2] + x2 * kSinTaylor[3])));
  c = 1.0f + x2 * (kCosTaylor[0] + x2 * (kCosTaylor[1] + x2 * (kCosTaylor[2] + x2 * kCosTaylor[3])));
}
// sin and cos of 2 pi u for u in [0, 1]: u's quarter turns q = round(4u) are
// taken off exactly (4u - q is exact), the rest, within an eighth of a turn,
// goes to sinCosQuarterPi, and the result is turned back by q quarters.
inline void sinCosTwoPi(float u, float& s, float& c) {
  const float u4 = 4.0f * u, q = std::nearbyint(u4);
  float sr, cr;
  sinCosQuarterPi(2.0f * (u4 - q), sr, cr);
  const int k = int(q) & 3;
  const float a = (k & 1) ? cr : sr, b = (k & 1) ? sr : cr;
  s = (k & 2) ? -a : a;
  c = ((k + 1) & 2) ? -b : b;
}

// Builds an orthonormal basis around n (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited"). Continuous except at n.z = -1.
inline void coordinateSystem(const Vec3& n, Vec3& s, Vec3& t) {
  float sign = std::copysign(1.0f, n.z);
  float a = -1.0f / (sign + n.z);
  float b = n.x * n.y * a;
  s = Vec3(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x);
  t = Vec3(b, sign + n.y * n.y * a, -n.y);
}

// Orthonormal frame: local z is the normal, local x the tangent.
struct Frame {
  Vec3 s{1, 0, 0}, t{0, 1, 0}, n{0, 0, 1};
  Frame() = default;
  explicit Frame(const Vec3& normal) : n(normal) { coordinateSystem(n, s, t); }
  // Gram-Schmidt the tangent against the normal; falls back to an arbitrary
  // basis when the tangent is degenerate or parallel to the normal.
  Frame(const Vec3& normal, const Vec3& tangent) : n(normal) {
    Vec3 ts = tangent - n * dot(n, tangent);
    float l = length(ts);
    if (!(l > 1e-6f)) {
      coordinateSystem(n, s, t);
      return;
    }
    s = ts / l;
    t = cross(n, s);
  }
  Vec3 toLocal(const Vec3& v) const { return {dot(v, s), dot(v, t), dot(v, n)}; }
  Vec3 toWorld(const Vec3& v) const { return s * v.x + t * v.y + n * v.z; }
};

// Column-major 4x4 affine transform in double precision (glTF node matrices).
struct Mat4 {
  double m[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double& at(int row, int col) { return m[col * 4 + row]; }
  double at(int row, int col) const { return m[col * 4 + row]; }
  Mat4 operator*(const Mat4& o) const {
    Mat4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = 0;
        for (int k = 0; k < 4; ++k) s += at(i, k) * o.at(k, j);
        r.at(i, j) = s;
      }
    return r;
  }
  Vec3 point(const Vec3& p) const {
    return {float(at(0, 0) * p.x + at(0, 1) * p.y + at(0, 2) * p.z + at(0, 3)),
            float(at(1, 0) * p.x + at(1, 1) * p.y + at(1, 2) * p.z + at(1, 3)),
            float(at(2, 0) * p.x + at(2, 1) * p.y + at(2, 2) * p.z + at(2, 3))};
  }
  Vec3 vector(const Vec3& v) const {
    return {float(at(0, 0) * v.x + at(0, 1) * v.y + at(0, 2) * v.z),
            float(at(1, 0) * v.x + at(1, 1) * v.y + at(1, 2) * v.z),
            float(at(2, 0) * v.x + at(2, 1) * v.y + at(2, 2) * v.z)};
  }
  double det3() const {
    return at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
           at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
           at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
  }
  // Normals transform by the inverse transpose of the upper 3x3; the cofactor
  // matrix is that up to a positive-or-negative scale, which normalize() and
  // the sign of det3() take care of.
  Vec3 normal(const Vec3& n) const {
    double c[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[i][j] = at(i1, j1) * at(i2, j2) - at(i1, j2) * at(i2, j1);
      }
    double s = det3() < 0 ? -1.0 : 1.0;
    return normalize(Vec3(float(s * (c[0][0] * n.x + c[0][1] * n.y + c[0][2] * n.z)),
                          float(s * (c[1][0] * n.x + c[1][1] * n.y + c[1][2] * n.z)),
                          float(s * (c[2][0] * n.x + c[2][1] * n.y + c[2][2] * n.z))));
  }
};

}  // namespace vsl
