// Sections: [1] SG primitives  [2] the lobes  [3] the transfer
#include "core/vsl_sg.h"

#include <algorithm>
#include <cmath>

namespace vsl {

namespace {

// A unit vector in double. Sharpnesses reach 1e12 (needle cones), so a float
// axis's length error (1e-7) would put 1e5 into an exponent: every axis is
// renormalised in double before it is scaled.
struct Unit {
  double x, y, z;
  explicit Unit(const Vec3& v) {
    const double l = std::sqrt(double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z);
    const double s = l > 0 ? 1.0 / l : 0.0;
    x = v.x * s;
    y = v.y * s;
    z = v.z * s;
  }
  double dot(const Unit& o) const { return x * o.x + y * o.y + z * o.z; }
};

}  // namespace

// ---- [1] SG primitives ------------------------------------------------------------

double SphericalGaussian::eval(const Vec3& l) const {
  return std::exp(logAmplitude + lambda * (Unit(axis).dot(Unit(l)) - 1.0));
}

double sgLogIntegral(double vx, double vy, double vz, double B) {
  // Formula (1) of the header: the integral of exp(v.l) over the sphere is
  // 4 pi sinh(|v|) / |v| = 2 pi exp(|v|) (1 - exp(-2|v|)) / |v|, and the
  // last factor tends to 2 as |v| -> 0.
  const double m = std::sqrt(vx * vx + vy * vy + vz * vz);
  if (!(m > 1e-12)) return std::log(4.0 * M_PI) - B;
  return std::log(2.0 * M_PI) + (m - B) + std::log(-std::expm1(-2.0 * m) / m);
}

double sgProductIntegral(std::span<const SphericalGaussian> g) {
  double vx = 0, vy = 0, vz = 0, B = 0;
  for (const SphericalGaussian& s : g) {
    const Unit u(s.axis);
    vx += s.lambda * u.x;
    vy += s.lambda * u.y;
    vz += s.lambda * u.z;
    B += s.lambda - s.logAmplitude;
  }
  return std::exp(sgLogIntegral(vx, vy, vz, B));
}

double sgSharpnessForSolidAngle(double omc) {
  omc = std::clamp(omc, 1e-300, 1.0);
  // h(lambda) = 1 - exp(-2 lambda) - omc lambda is concave with h(1/omc) <= 0
  // right of its positive root, so Newton's steps from 1/omc fall
  // monotonically onto the root. Below omc = 0.05 exp(-2/omc) < 5e-18 and
  // 1/omc is the root to double precision.
  double lambda = 1.0 / omc;
  if (omc < 0.05) return lambda;
  for (int i = 0; i < 20; ++i) {
    const double e = std::exp(-2.0 * lambda);
    const double h = 1.0 - e - omc * lambda, dh = 2.0 * e - omc;
    const double step = h / dh;
    lambda -= step;
    if (std::abs(step) < 1e-12 * lambda) break;
  }
  return lambda;
}

// ---- [2] The lobes ---------------------------------------------------------------

SgLobe sgSpecularLobe(const BrdfAt& f) {
  SgLobe lobe;
  const Brdf& b = f.brdf();
  const Vec3& w = f.w();
  if (!f.specularOn() || !(w.z > 0) || (b.metallic <= 0 && b.specularWeight <= 0)) return lobe;
  // Wang et al. 2009: D ~ G(h; n, 2/alpha^2), warped about the mirror
  // direction with the reflection's Jacobian 4 w.h (h = n at the peak). A
  // grazing w would make the lobe a needle; 0.01 bounds it.
  const double alpha2 = double(b.ggx.ax) * double(b.ggx.ay);
  lobe.axis = Vec3(-w.x, -w.y, w.z);
  lobe.lambda = 2.0 / alpha2 / (4.0 * std::max(double(w.z), 0.01));
  lobe.on = true;
  return lobe;
}

namespace {

// The GGX normal distribution of f's lobe seen from the outgoing direction wi
// (local): log(D(h) / D_max), D_max = 1/(pi ax ay), and its derivative per
// radian along the great circle from wi toward the lobe's axis m, with the
// sine of the angle between them.
struct NdfAt {
  double e = 1, slope = 0, sinPsi = 0;  // D / D_max = 1 / e^2
  double logRatio() const { return -2.0 * std::log(e); }
};
NdfAt ndfAt(const BrdfAt& f, const Vec3& wi, const Vec3& m) {
  const GGX& g = f.brdf().ggx;
  const Unit w(f.w()), l(wi), mu(m);
  // h = (w + l) / |w + l|; D = D_max / e^2 with e = h.M h, M = diag(1/ax^2, 1/ay^2, 1).
  double h[3] = {w.x + l.x, w.y + l.y, w.z + l.z};
  const double len = std::sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
  NdfAt r;
  if (!(len > 0)) return r;
  for (double& c : h) c /= len;
  const double Mh[3] = {h[0] / (double(g.ax) * g.ax), h[1] / (double(g.ay) * g.ay), h[2]};
  const double e = h[0] * Mh[0] + h[1] * Mh[1] + h[2] * Mh[2];
  r.e = e;
  // The tangent at wi toward m; d h = (I - h h^T) d l / |w + l|, so
  // d log D = -4 / (e |w + l|) (M h - e h) . d l.
  const double c = mu.dot(l);
  double t[3] = {mu.x - c * l.x, mu.y - c * l.y, mu.z - c * l.z};
  r.sinPsi = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
  if (!(r.sinPsi > 1e-9)) return r;
  for (double& v : t) v /= r.sinPsi;
  const double mht = Mh[0] * t[0] + Mh[1] * t[1] + Mh[2] * t[2], ht = h[0] * t[0] + h[1] * t[1] + h[2] * t[2];
  r.slope = -4.0 / (e * len) * (mht - e * ht);
  return r;
}

// ---- [3] The transfer --------------------------------------------------------------

// One factor's contribution to the exponent of formula (1): lambda u.l - B.
struct SgExponent {
  double v[3] = {0, 0, 0};
  double B = 0;
  void add(const Unit& u, double lambda, double b) {
    v[0] += lambda * u.x;
    v[1] += lambda * u.y;
    v[2] += lambda * u.z;
    B += lambda * b;
  }
  // Formula (1) without the logs of sgLogIntegral (one exp; the factor
  // 1 - exp(-2|v|) is 1 to double precision past |v| = 19).
  double integral() const {
    const double m = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(m > 1e-12)) return 4.0 * M_PI * std::exp(-B);
    const double tail = m > 19.0 ? 1.0 : -std::expm1(-2.0 * m);
    return 2.0 * M_PI * std::exp(m - B) * tail / m;
  }
};

// A specular lobe as a factor of the product, relative to its value S(a) at
// the axis: the SG exp(lambda u.l - B) in world directions l from x toward p
// (header item 4).
struct LobeFactor {
  Unit u{Vec3(0, 0, 1)};
  double lambda = 0, B = 0;
  bool on = false;
};
LobeFactor lobeFactor(const SgLobe& lobe, const Vec3& uWorld, const Unit& a, const NdfAt& ndf, double coneChord) {
  LobeFactor f;
  if (!lobe.on) return f;
  f.u = Unit(uWorld);
  const double cu = f.u.dot(a);
  // The local fit: exp(lambdaLocal (u.l - u.a)), the NDF's value and slope
  // at a toward the axis (lambdaLocal sin psi = slope). In GGX's tail the
  // slope falls like 1/angle, so this SG's value at the lobe's axis stays
  // within about e^2 of S(a): it does not extrapolate the tail into a peak.
  double lambdaLocal = ndf.sinPsi > 1e-7 ? std::clamp(ndf.slope / ndf.sinPsi, 0.0, lobe.lambda) : lobe.lambda;
  // Nor may it rise above the lobe's own peak, D_max / D(h_a), at u (an
  // anisotropic lobe's slope across its narrow axis would otherwise be
  // extrapolated far past the streak it crosses).
  const double logPeak = -ndf.logRatio(), rise = 1.0 - cu;
  if (rise > 1e-12) lambdaLocal = std::min(lambdaLocal, std::max(logPeak, 0.0) / rise);
  // The global fit: S(a) (D_max / D(h_a)) exp(lambda (u.l - 1)), the NDF
  // fit's peak. Its share: about the part of the lobe's mass inside the cone
  // (angle theta_c), the lobe taken as a 2D Gaussian of variance 1/lambda
  // about its axis at angle psi from a: the share of a centred lobe inside,
  // 1 - exp(-lambda theta_c^2 / 2), times a Gaussian fall-off as the axis
  // leaves the cone. The local fit keeps the rest: all of it where the lobe
  // is wide against the cone (then S is nearly linear over the cone) or its
  // axis far outside (the cone sees the tail), so that r -> 0 gives the VPL.
  // Angles as chords (2 sin(angle / 2), from 1 - cos without a trigonometric
  // call; within 4% of the angle up to 60 degrees).
  const double chordPsi = std::sqrt(2.0 * std::max(0.0, 1.0 - cu)), outside = std::max(0.0, chordPsi - coneChord);
  const double inside = 0.5 * lobe.lambda * coneChord * coneChord, away = 0.5 * lobe.lambda * outside * outside;
  const double global = away > 40.0 ? 0.0 : -std::expm1(-inside) * std::exp(-away), local = 1.0 - global;
  f.lambda = local * lambdaLocal + global * lobe.lambda;
  f.B = local * lambdaLocal * cu + global * (lobe.lambda - logPeak);
  f.on = true;
  return f;
}

// Adds amplitude x the integral of base x (lobes), one of the four terms, to
// sum (in double: a tail's small amplitude may meet a large integral).
void addTerm(const Vec3& amplitude, const SgExponent& base, const LobeFactor* fx, const LobeFactor* fp, double sum[3]) {
  if (isBlack(amplitude)) return;
  SgExponent e = base;
  for (const LobeFactor* f : {fx, fp}) {
    if (!f) continue;
    if (!f->on) return;
    e.add(f->u, f->lambda, 0.0);
    e.B += f->B;
  }
  const double s = e.integral();
  for (int c = 0; c < 3; ++c) sum[c] += double(amplitude[c]) * s;
}

}  // namespace

bool vslUsesSg(const VslOptions& options, double radius, double d) {
  if (options.integral != VslIntegral::Sg) return false;
  // Every cone is at most a hemisphere (1 - cos <= 1): no need to measure it.
  return options.sgMaxOneMinusCos >= 1 || vslConeOneMinusCos(radius, d) <= options.sgMaxOneMinusCos;
}

VslResult vslTransferSg(const VslReceiver& x, const VslEmitter& p, const Vec3& toLight, double radius,
                        const VslOptions& options) {
  VslResult res;
  // The cone's axis and its SG; a point exactly at the light looks along its
  // normal (as the quadrature).
  const float d = length(toLight);
  const Vec3 a = d > 0 ? toLight / d : x.frame.n;
  const double omc = vslConeOneMinusCos(radius, d), lambdaC = sgSharpnessForSolidAngle(omc);
  const double coneChord = std::sqrt(2.0 * omc);  // 2 sin(theta_c / 2)
  const Vec3 lx = x.frame.toLocal(a), lp = p.frame.toLocal(-a);
  const float cosX = lx.z, cosP = p.cosine(lp);
  if (!(cosX > 0 && cosP > 0)) return res;
  // Every factor at the axis (exact there), lobes apart.
  const BrdfAt::Parts fx = x.f.evalParts(lx), fp = p.f.evalParts(lp);
  // The cone and the two cosines (ratio form), shared by the four terms.
  const Unit ua(a), nx(x.frame.n), np(-p.frame.toWorld(p.geometricCosine ? p.ngLocal : Vec3(0, 0, 1)));
  SgExponent base;
  base.add(ua, lambdaC, 1.0);
  base.add(nx, kSgCosineSharpness, nx.dot(ua));
  base.add(np, kSgCosineSharpness, np.dot(ua));
  // The specular lobes: x's about its mirror direction, p's about its own
  // (leaving p; seen from x along -that).
  const SgLobe sx = sgSpecularLobe(x.f), sp = sgSpecularLobe(p.f);
  const LobeFactor lobeX = isBlack(fx.specular)
                               ? LobeFactor{}
                               : lobeFactor(sx, x.frame.toWorld(sx.axis), ua, ndfAt(x.f, lx, sx.axis), coneChord);
  const LobeFactor lobeP = isBlack(fp.specular)
                               ? LobeFactor{}
                               : lobeFactor(sp, -p.frame.toWorld(sp.axis), ua, ndfAt(p.f, lp, sp.axis), coneChord);
  const float cc = cosX * cosP;
  double sum[3] = {0, 0, 0};
  addTerm(fx.diffuse * fp.diffuse * cc, base, nullptr, nullptr, sum);
  addTerm(fx.diffuse * fp.specular * cc, base, nullptr, &lobeP, sum);
  addTerm(fx.specular * fp.diffuse * cc, base, &lobeX, nullptr, sum);
  addTerm(fx.specular * fp.specular * cc, base, &lobeX, &lobeP, sum);
  // The quadrature's normalisation.
  const double area = options.clippedDisk ? vslClippedDiskArea(radius, dot(toLight, x.ng)) : M_PI * radius * radius;
  if (!(area > 0)) return res;
  const double norm = 1.0 / area;
  const Vec3 t(float(sum[0] * norm), float(sum[1] * norm), float(sum[2] * norm));
  res.transfer = isFinite(t) ? t : Vec3(0.0f);
  return res;
}

}  // namespace vsl
