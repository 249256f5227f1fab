// AVX-512 loops of the step (avx512_kernels.h): the pair-force loop (loads, transposes and the
// lane type; the arithmetic is contact_law.h's), and the drift and body sums of bodies of one
// or two discs, where every arithmetic line mirrors an operation of the portable code
// (integrator.cpp's PlaceDisc, force_pass.cpp's BodySumsUpTo2) in the same order. With contraction off
// (CMakeLists.txt) each is one correctly rounded IEEE operation, as in the scalar code.
#include "engine/avx512_kernels.h"

#include <cstddef>
#include <algorithm>
#include <cstdint>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define GRANARY_HAVE_AVX512_KERNEL 1
// GCC 12's AVX-512 unpack intrinsics pass an undefined vector as the merge source of an
// all-ones mask and then warn that it may be used uninitialized (GCC bug 105593).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace granary::engine {

#ifdef GRANARY_HAVE_AVX512_KERNEL

bool Avx512Available() {
  static const bool kAvailable = __builtin_cpu_supports("avx512f");
  return kAvailable;
}

namespace {

#define GRANARY_AVX512 __attribute__((target("avx512f"), always_inline)) inline

// The fields the pair law reads of eight disc records, one lane per record.
struct Lanes {
  __m512d x, y, vx, vy, r, w;
};

// Loads the records kin[idx[0..7]] (one 64-byte line each: x y vx vy r w pad pad) and
// transposes them: unpack pairs of rows, then two rounds of 128-bit lane shuffles.
GRANARY_AVX512 Lanes LoadLanes(const DiscKin* kin, const int* idx) {
  __m512d row[8];
  for (int k = 0; k < 8; ++k) row[k] = _mm512_load_pd(&kin[idx[k]].x);
  // t_even: 128-bit lanes (x, vx, r, pad0) of rows 2m, 2m+1; t_odd: (y, vy, w, pad1).
  const __m512d t0 = _mm512_unpacklo_pd(row[0], row[1]), t1 = _mm512_unpackhi_pd(row[0], row[1]);
  const __m512d t2 = _mm512_unpacklo_pd(row[2], row[3]), t3 = _mm512_unpackhi_pd(row[2], row[3]);
  const __m512d t4 = _mm512_unpacklo_pd(row[4], row[5]), t5 = _mm512_unpackhi_pd(row[4], row[5]);
  const __m512d t6 = _mm512_unpacklo_pd(row[6], row[7]), t7 = _mm512_unpackhi_pd(row[6], row[7]);
  constexpr int kLow = 0x44;   // (a.L0, a.L1, b.L0, b.L1)
  constexpr int kHigh = 0xEE;  // (a.L2, a.L3, b.L2, b.L3)
  constexpr int kEven = 0x88;  // (a.L0, a.L2, b.L0, b.L2)
  constexpr int kOdd = 0xDD;   // (a.L1, a.L3, b.L1, b.L3)
  const __m512d xv0 = _mm512_shuffle_f64x2(t0, t2, kLow), xv1 = _mm512_shuffle_f64x2(t4, t6, kLow);
  const __m512d yv0 = _mm512_shuffle_f64x2(t1, t3, kLow), yv1 = _mm512_shuffle_f64x2(t5, t7, kLow);
  const __m512d r0 = _mm512_shuffle_f64x2(t0, t2, kHigh), r1 = _mm512_shuffle_f64x2(t4, t6, kHigh);
  const __m512d w0 = _mm512_shuffle_f64x2(t1, t3, kHigh), w1 = _mm512_shuffle_f64x2(t5, t7, kHigh);
  Lanes l;
  l.x = _mm512_shuffle_f64x2(xv0, xv1, kEven);
  l.vx = _mm512_shuffle_f64x2(xv0, xv1, kOdd);
  l.y = _mm512_shuffle_f64x2(yv0, yv1, kEven);
  l.vy = _mm512_shuffle_f64x2(yv0, yv1, kOdd);
  l.r = _mm512_shuffle_f64x2(r0, r1, kEven);
  l.w = _mm512_shuffle_f64x2(w0, w1, kEven);
  return l;
}

GRANARY_AVX512 __m512d Mul(__m512d a, __m512d b) { return _mm512_mul_pd(a, b); }
GRANARY_AVX512 __m512d Add(__m512d a, __m512d b) { return _mm512_add_pd(a, b); }
GRANARY_AVX512 __m512d Sub(__m512d a, __m512d b) { return _mm512_sub_pd(a, b); }
GRANARY_AVX512 __m512d Neg(__m512d a) {
  return _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(a), _mm512_set1_epi64(INT64_MIN)));
}
// m ? b : a
GRANARY_AVX512 __m512d Select(__mmask8 m, __m512d b, __m512d a) { return _mm512_mask_blend_pd(m, a, b); }

// The contact kernel's value type for eight entries (contact_law.h): one lane each, every
// operation one AVX-512 instruction, correctly rounded as the scalar one. Its operations are
// inline but not always_inline: the kernel templates (no target) cannot take target code
// inline; the flatten of PairEntriesImpl inlines all of it there.
#define GRANARY_LANE __attribute__((target("avx512f"))) inline
struct Mask8 {
  __mmask8 m;
};
struct Lane8 {
  __m512d v;
  Lane8() = default;
  GRANARY_LANE Lane8(__m512d x) : v(x) {}
  GRANARY_LANE explicit Lane8(double x) : v(_mm512_set1_pd(x)) {}
};
GRANARY_LANE Lane8 operator+(Lane8 a, Lane8 b) { return _mm512_add_pd(a.v, b.v); }
GRANARY_LANE Lane8 operator-(Lane8 a, Lane8 b) { return _mm512_sub_pd(a.v, b.v); }
GRANARY_LANE Lane8 operator*(Lane8 a, Lane8 b) { return _mm512_mul_pd(a.v, b.v); }
GRANARY_LANE Lane8 operator/(Lane8 a, Lane8 b) { return _mm512_div_pd(a.v, b.v); }
GRANARY_LANE Lane8 operator-(Lane8 a) { return Neg(a.v); }
GRANARY_LANE Mask8 operator<(Lane8 a, Lane8 b) { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_LT_OQ)}; }
GRANARY_LANE Mask8 operator>(Lane8 a, Lane8 b) { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_GT_OQ)}; }
GRANARY_LANE Mask8 operator!=(Lane8 a, Lane8 b) { return {_mm512_cmp_pd_mask(a.v, b.v, _CMP_NEQ_UQ)}; }
GRANARY_LANE Mask8 operator&(Mask8 a, Mask8 b) { return {static_cast<__mmask8>(a.m & b.m)}; }
GRANARY_LANE Lane8 Sqrt(Lane8 a) { return _mm512_sqrt_pd(a.v); }
GRANARY_LANE Lane8 Abs(Lane8 a) { return _mm512_abs_pd(a.v); }
GRANARY_LANE Lane8 Select(Mask8 m, Lane8 if_true, Lane8 if_false) {
  return _mm512_mask_blend_pd(m.m, if_false.v, if_true.v);
}
GRANARY_LANE bool NeedAny(Mask8 m) { return m.m != 0; }
GRANARY_LANE void Store(double* p, Lane8 a) { _mm512_storeu_pd(p, a.v); }

}  // namespace

template <>
GRANARY_LANE Lane8 Load<Lane8>(const double* p) {
  return _mm512_loadu_pd(p);
}
#undef GRANARY_LANE

namespace {

template <class Normal, bool kLiggghtsCap>
__attribute__((target("avx512f"), flatten)) int PairEntriesImpl(
    int e0, int e1, const int* __restrict nl_i, const int* __restrict nl_j, const double* __restrict nl_reff,
    const double* __restrict nl_meff, double* __restrict nl_sx, double* __restrict nl_sy, double* __restrict nl_fx,
    double* __restrict nl_fy, double* __restrict nl_c, const DiscKin* __restrict kin, const ContactParams& pp,
    double dt) {
  const LawConstants<Lane8> law(pp, dt);
  int e = e0;
  for (; e + 8 <= e1; e += 8) {
    const Lanes a = LoadLanes(kin, nl_i + e);
    const Lanes b = LoadLanes(kin, nl_j + e);
    PairEntry<Normal, kLiggghtsCap>(DiscState<Lane8>{a.x, a.y, a.vx, a.vy, a.r, a.w},
                                    DiscState<Lane8>{b.x, b.y, b.vx, b.vy, b.r, b.w}, nl_reff + e, nl_meff + e,
                                    nl_sx + e, nl_sy + e, nl_fx + e, nl_fy + e, nl_c + e, law);
  }
  return e;
}

// Stores eight records kin[first + stride m], m = 0..7, from the lanes of x y vx vy r w
// (pads zero), the inverse of LoadLanes: unpack pairs of fields, then two rounds of
// 128-bit lane shuffles give one 64-byte row per record.
GRANARY_AVX512 void StoreLanes(DiscKin* first, int stride, const Lanes& l) {
  const __m512d zero = _mm512_setzero_pd();
  const __m512d t0 = _mm512_unpacklo_pd(l.x, l.y), t1 = _mm512_unpackhi_pd(l.x, l.y);
  const __m512d t2 = _mm512_unpacklo_pd(l.vx, l.vy), t3 = _mm512_unpackhi_pd(l.vx, l.vy);
  const __m512d t4 = _mm512_unpacklo_pd(l.r, l.w), t5 = _mm512_unpackhi_pd(l.r, l.w);
  // t0 128-bit lane q: (x, y) of record 2q; t1: of record 2q + 1; likewise t2, t3 (vx, vy)
  // and t4, t5 (r, w); the pads are zero.
  constexpr int kEven = 0x88, kOdd = 0xDD;
  const __m512d a0 = _mm512_shuffle_f64x2(t0, t2, kEven), a1 = _mm512_shuffle_f64x2(t4, zero, kEven);
  const __m512d b0 = _mm512_shuffle_f64x2(t0, t2, kOdd), b1 = _mm512_shuffle_f64x2(t4, zero, kOdd);
  const __m512d c0 = _mm512_shuffle_f64x2(t1, t3, kEven), c1 = _mm512_shuffle_f64x2(t5, zero, kEven);
  const __m512d d0 = _mm512_shuffle_f64x2(t1, t3, kOdd), d1 = _mm512_shuffle_f64x2(t5, zero, kOdd);
  // Record 0 = (a0.L0, a0.L2, a1.L0, a1.L2) and record 4 = (a0.L1, a0.L3, a1.L1, a1.L3);
  // likewise records 2 and 6 from b0 and b1, 1 and 5 from c0 and c1, 3 and 7 from d0 and d1.
  constexpr int kRowA = 0x88, kRowB = 0xDD;
  DiscKin* base = first;
  const std::ptrdiff_t st = stride;
  _mm512_store_pd(&base[0 * st].x, _mm512_shuffle_f64x2(a0, a1, kRowA));
  _mm512_store_pd(&base[4 * st].x, _mm512_shuffle_f64x2(a0, a1, kRowB));
  _mm512_store_pd(&base[2 * st].x, _mm512_shuffle_f64x2(b0, b1, kRowA));
  _mm512_store_pd(&base[6 * st].x, _mm512_shuffle_f64x2(b0, b1, kRowB));
  _mm512_store_pd(&base[1 * st].x, _mm512_shuffle_f64x2(c0, c1, kRowA));
  _mm512_store_pd(&base[5 * st].x, _mm512_shuffle_f64x2(c0, c1, kRowB));
  _mm512_store_pd(&base[3 * st].x, _mm512_shuffle_f64x2(d0, d1, kRowA));
  _mm512_store_pd(&base[7 * st].x, _mm512_shuffle_f64x2(d0, d1, kRowB));
}

// Lanes pick[m] of the 16 values at a: every other one (pick = even or odd indices).
GRANARY_AVX512 __m512d Deinterleave(const double* a, __m512i pick) {
  return _mm512_permutex2var_pd(_mm512_loadu_pd(a), pick, _mm512_loadu_pd(a + 8));
}

// Disc k of eight bodies of kDiscs discs each from the disc array at a (dumbbells: every
// other value of 16, even or odd).
template <int kDiscs>
GRANARY_AVX512 __m512d DiscLanes(const double* a, int k, __m512i even, __m512i odd) {
  if constexpr (kDiscs == 1) return _mm512_loadu_pd(a);
  return Deinterleave(a, k == 0 ? even : odd);
}

// DriftUniformAvx512: groups of eight bodies, the body part of integrator.cpp's DriftKernel and
// the disc part of its DiscKernelUniform<kDiscs> in one pass (the body state stays in
// registers).
template <int kDiscs>
__attribute__((target("avx512f"))) int DriftUniformImpl(int b0, int b1, const DriftArrays& arr, double dt_scalar,
                                                        const double box[3], double limit_scalar, bool* beyond,
                                                        bool* moved) {
  static_assert(kDiscs == 1 || kDiscs == 2);
  const std::uint8_t* __restrict active = arr.active;
  double* __restrict bx = arr.bx;
  double* __restrict by = arr.by;
  double* __restrict bth = arr.bth;
  double* __restrict bvx = arr.bvx;
  double* __restrict bvy = arr.bvy;
  double* __restrict bw = arr.bw;
  double* __restrict bc = arr.bc;
  double* __restrict bs = arr.bs;
  const double* __restrict dox = arr.dox;
  const double* __restrict doy = arr.doy;
  const double* __restrict dr = arr.dr;
  const double* __restrict refx = arr.refx;
  const double* __restrict refy = arr.refy;
  double* __restrict dx = arr.dx;
  double* __restrict dy = arr.dy;
  DiscKin* __restrict kin = arr.kin;
  // Dumbbells: disc k of the eight bodies is lanes 2 m + k of two consecutive vectors.
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14);
  const __m512i odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  const __m512i mix_lo = _mm512_setr_epi64(0, 8, 1, 9, 2, 10, 3, 11);
  const __m512i mix_hi = _mm512_setr_epi64(4, 12, 5, 13, 6, 14, 7, 15);
  const __m512d dt = _mm512_set1_pd(dt_scalar), half = _mm512_set1_pd(0.5 * dt_scalar);
  const __m512d limit = _mm512_set1_pd(limit_scalar);
  const __m512d xmin = _mm512_set1_pd(box[0]), xmax = _mm512_set1_pd(box[1]), ymin = _mm512_set1_pd(box[2]);
  const __m512d one = _mm512_set1_pd(1.0), small_angle = _mm512_set1_pd(0.01);
  const __m512d k2 = _mm512_set1_pd(1.0 / 2), k12 = _mm512_set1_pd(1.0 / 12), k30 = _mm512_set1_pd(1.0 / 30);
  const __m512d k56 = _mm512_set1_pd(1.0 / 56), k6 = _mm512_set1_pd(1.0 / 6), k20 = _mm512_set1_pd(1.0 / 20);
  const __m512d k42 = _mm512_set1_pd(1.0 / 42), k1_5 = _mm512_set1_pd(1.5), k0_5 = _mm512_set1_pd(0.5);
  __mmask8 far = 0, out = 0;
  int b = b0;
  for (; b + 8 <= b1; b += 8) {
    // DriftKernel
    const __mmask8 on = _mm512_test_epi64_mask(
        _mm512_cvtepu8_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(active + b))), _mm512_set1_epi64(0xff));
    const __m512d vx =
        Add(_mm512_loadu_pd(bvx + b), Mul(Mul(half, _mm512_loadu_pd(arr.bfx + b)), _mm512_loadu_pd(arr.binv_mass + b)));
    const __m512d vy =
        Add(_mm512_loadu_pd(bvy + b), Mul(Mul(half, _mm512_loadu_pd(arr.bfy + b)), _mm512_loadu_pd(arr.binv_mass + b)));
    const __m512d w = Add(_mm512_loadu_pd(bw + b),
                          Mul(Mul(half, _mm512_loadu_pd(arr.btq + b)), _mm512_loadu_pd(arr.binv_inertia + b)));
    const __m512d a = Mul(dt, w);
    const __mmask8 small = _mm512_cmp_pd_mask(_mm512_abs_pd(a), small_angle, _CMP_LT_OQ);
    if ((on & ~small) != 0) break;  // a rotation that needs libm: the caller takes this group
    const __m512d a2 = Mul(a, a);
    const __m512d ca =
        Sub(one, Mul(Mul(a2, k2), Sub(one, Mul(Mul(a2, k12), Sub(one, Mul(Mul(a2, k30), Sub(one, Mul(a2, k56))))))));
    const __m512d sa = Mul(a, Sub(one, Mul(Mul(a2, k6), Sub(one, Mul(Mul(a2, k20), Sub(one, Mul(a2, k42)))))));
    const __m512d c0 = _mm512_loadu_pd(bc + b), s0 = _mm512_loadu_pd(bs + b);
    const __m512d c1 = Sub(Mul(c0, ca), Mul(s0, sa)), s1 = Add(Mul(s0, ca), Mul(c0, sa));
    const __m512d f = Sub(k1_5, Mul(k0_5, Add(Mul(c1, c1), Mul(s1, s1))));
    const __m512d x0 = _mm512_loadu_pd(bx + b), y0 = _mm512_loadu_pd(by + b);
    const __m512d xn = Add(x0, Mul(dt, vx)), yn = Add(y0, Mul(dt, vy));
    const __m512d th = Add(_mm512_loadu_pd(bth + b), a);
    // The state of the eight bodies after the drift (an inactive body keeps its own).
    const __m512d x = Select(on, xn, x0), y = Select(on, yn, y0);
    const __m512d c = Select(on, Mul(c1, f), c0), s = Select(on, Mul(s1, f), s0);
    const __m512d vxs = Select(on, vx, _mm512_loadu_pd(bvx + b)), vys = Select(on, vy, _mm512_loadu_pd(bvy + b));
    const __m512d ws = Select(on, w, _mm512_loadu_pd(bw + b));
    _mm512_storeu_pd(bx + b, x);
    _mm512_storeu_pd(by + b, y);
    _mm512_mask_storeu_pd(bth + b, on, th);
    _mm512_storeu_pd(bvx + b, vxs);
    _mm512_storeu_pd(bvy + b, vys);
    _mm512_storeu_pd(bw + b, ws);
    _mm512_storeu_pd(bc + b, c);
    _mm512_storeu_pd(bs + b, s);
    const int outside = _mm512_cmp_pd_mask(xn, xmin, _CMP_LT_OQ) | _mm512_cmp_pd_mask(xn, xmax, _CMP_GT_OQ) |
                        _mm512_cmp_pd_mask(yn, ymin, _CMP_LT_OQ);
    out = static_cast<__mmask8>(out | (on & outside));
    // DiscKernelUniform (PlaceDisc)
    const std::ptrdiff_t d0 = kDiscs * static_cast<std::ptrdiff_t>(b);
    __m512d px[kDiscs], py[kDiscs];
    for (int k = 0; k < kDiscs; ++k) {
      const __m512d ox = DiscLanes<kDiscs>(dox + d0, k, even, odd), oy = DiscLanes<kDiscs>(doy + d0, k, even, odd);
      const __m512d wx = Sub(Mul(c, ox), Mul(s, oy));
      const __m512d wy = Add(Mul(s, ox), Mul(c, oy));
      px[k] = Add(x, wx);
      py[k] = Add(y, wy);
      Lanes l;
      l.x = px[k];
      l.y = py[k];
      l.vx = Sub(vxs, Mul(ws, wy));
      l.vy = Add(vys, Mul(ws, wx));
      l.r = DiscLanes<kDiscs>(dr + d0, k, even, odd);
      l.w = ws;
      StoreLanes(kin + d0 + k, kDiscs, l);
      const __m512d ddx = Sub(px[k], DiscLanes<kDiscs>(refx + d0, k, even, odd));
      const __m512d ddy = Sub(py[k], DiscLanes<kDiscs>(refy + d0, k, even, odd));
      far |= _mm512_cmp_pd_mask(Add(Mul(ddx, ddx), Mul(ddy, ddy)), limit, _CMP_GT_OQ);
    }
    if constexpr (kDiscs == 1) {
      _mm512_storeu_pd(dx + d0, px[0]);
      _mm512_storeu_pd(dy + d0, py[0]);
    } else {
      _mm512_storeu_pd(dx + d0, _mm512_permutex2var_pd(px[0], mix_lo, px[1]));
      _mm512_storeu_pd(dx + d0 + 8, _mm512_permutex2var_pd(px[0], mix_hi, px[1]));
      _mm512_storeu_pd(dy + d0, _mm512_permutex2var_pd(py[0], mix_lo, py[1]));
      _mm512_storeu_pd(dy + d0 + 8, _mm512_permutex2var_pd(py[0], mix_hi, py[1]));
    }
  }
  if (far != 0) *moved = true;
  if (out != 0) *beyond = true;
  return b;
}

// PlaceDiscsAvx512: eight discs at a time; their bodies are at most eight consecutive ones
// (every body has a disc), whose state is loaded and spread to the discs by permutes.
GRANARY_AVX512 __m512d BodyLanes(const double* a, int first, __mmask8 valid, __m512i pick) {
  return _mm512_permutexvar_pd(pick, _mm512_maskz_loadu_pd(valid, a + first));
}

__attribute__((target("avx512f"))) int PlaceDiscsImpl(int d0, int d1, double limit_scalar, const int* __restrict dbody,
                                                      int body_end, const DriftArrays& arr, bool* moved) {
  const __m512d limit = _mm512_set1_pd(limit_scalar);
  __mmask8 far = 0;
  int d = d0;
  for (; d + 8 <= d1; d += 8) {
    const int first = dbody[d];
    // (bodies from body_end on are masked off: another thread may be writing them)
    const int past = first + 8 - body_end;
    const __mmask8 valid = past <= 0 ? __mmask8{0xff} : static_cast<__mmask8>(0xffu >> std::min(8, past));
    const __m512i pick =
        _mm512_sub_epi64(_mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(dbody + d))),
                         _mm512_set1_epi64(first));
    const __m512d x = BodyLanes(arr.bx, first, valid, pick), y = BodyLanes(arr.by, first, valid, pick);
    const __m512d vx = BodyLanes(arr.bvx, first, valid, pick), vy = BodyLanes(arr.bvy, first, valid, pick);
    const __m512d w = BodyLanes(arr.bw, first, valid, pick);
    const __m512d c = BodyLanes(arr.bc, first, valid, pick), s = BodyLanes(arr.bs, first, valid, pick);
    // PlaceDisc
    const __m512d ox = _mm512_loadu_pd(arr.dox + d), oy = _mm512_loadu_pd(arr.doy + d);
    const __m512d wx = Sub(Mul(c, ox), Mul(s, oy));
    const __m512d wy = Add(Mul(s, ox), Mul(c, oy));
    const __m512d px = Add(x, wx), py = Add(y, wy);
    _mm512_storeu_pd(arr.dx + d, px);
    _mm512_storeu_pd(arr.dy + d, py);
    Lanes l;
    l.x = px;
    l.y = py;
    l.vx = Sub(vx, Mul(w, wy));
    l.vy = Add(vy, Mul(w, wx));
    l.r = _mm512_loadu_pd(arr.dr + d);
    l.w = w;
    StoreLanes(arr.kin + d, 1, l);
    const __m512d ddx = Sub(px, _mm512_loadu_pd(arr.refx + d)), ddy = Sub(py, _mm512_loadu_pd(arr.refy + d));
    far |= _mm512_cmp_pd_mask(Add(Mul(ddx, ddx), Mul(ddy, ddy)), limit, _CMP_GT_OQ);
  }
  if (far != 0) *moved = true;
  return d;
}

// BodySumsUpTo2Avx512: the discs of eight consecutive bodies lie in [base, base + 16)
// (base: the first one's first disc); a field of them is two loads, and a body's first and
// second disc are picked from those by permutes (a body of one disc takes its first twice,
// and the select drops the second).
GRANARY_AVX512 void LoadPair(const double* a, std::ptrdiff_t base, __mmask8 hi_valid, __m512i first, __m512i second,
                             __m512d* v0, __m512d* v1) {
  const __m512d lo = _mm512_loadu_pd(a + base), hi = _mm512_maskz_loadu_pd(hi_valid, a + base + 8);
  *v0 = _mm512_permutex2var_pd(lo, first, hi);
  *v1 = _mm512_permutex2var_pd(lo, second, hi);
}

template <bool kKick>
__attribute__((target("avx512f"))) int BodySumsUpTo2Impl(int b0, int b1, const BodySumArrays& arr, int disc_end,
                                                         double g, double half_scalar, double dt_scalar,
                                                         double limit_scalar, bool* outrun) {
  const __m512d zero = _mm512_setzero_pd(), gv = _mm512_set1_pd(g), half = _mm512_set1_pd(half_scalar);
  const __m512d dt = _mm512_set1_pd(dt_scalar), limit = _mm512_set1_pd(limit_scalar), eps = _mm512_set1_pd(1e-9);
  __mmask8 out = 0;
  int b = b0;
  for (; b + 8 <= b1; b += 8) {
    const int base = arr.disc_begin[b];
    // Discs from disc_end on (another thread's, or beyond the arrays) are masked off.
    const int beyond = base + 16 - disc_end;
    const __mmask8 hi_valid = beyond <= 0 ? __mmask8{0xff} : static_cast<__mmask8>(0xffu >> std::min(8, beyond));
    const __m512i begin =
        _mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(arr.disc_begin + b)));
    const __m512i count = _mm512_cvtepi32_epi64(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(arr.disc_n + b)));
    const __mmask8 two = _mm512_cmpgt_epi64_mask(count, _mm512_set1_epi64(1));
    const __m512i first = _mm512_sub_epi64(begin, _mm512_set1_epi64(base));
    const __m512i second = _mm512_mask_add_epi64(first, two, first, _mm512_set1_epi64(1));
    __m512d fx0, fx1, fy0, fy1, tz0, tz1, x0, x1, y0, y1, rx0, rx1, ry0, ry1;
    LoadPair(arr.dfx, base, hi_valid, first, second, &fx0, &fx1);
    LoadPair(arr.dfy, base, hi_valid, first, second, &fy0, &fy1);
    LoadPair(arr.dtz, base, hi_valid, first, second, &tz0, &tz1);
    LoadPair(arr.dx, base, hi_valid, first, second, &x0, &x1);
    LoadPair(arr.dy, base, hi_valid, first, second, &y0, &y1);
    LoadPair(arr.refx, base, hi_valid, first, second, &rx0, &rx1);
    LoadPair(arr.refy, base, hi_valid, first, second, &ry0, &ry1);
    const __mmask8 on =
        _mm512_test_epi64_mask(_mm512_cvtepu8_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(arr.active + b))),
                               _mm512_set1_epi64(0xff));
    const __m512d cx = _mm512_loadu_pd(arr.bx + b), cy = _mm512_loadu_pd(arr.by + b);
    // BodySumsUpTo2
    __m512d bfx = Add(zero, fx0), bfy = Add(zero, fy0);
    __m512d btq = Add(zero, Add(Sub(Mul(Sub(x0, cx), fy0), Mul(Sub(y0, cy), fx0)), tz0));
    const __m512d mx = Sub(x0, rx0), my = Sub(y0, ry0);
    __m512d moved2 = _mm512_max_pd(Add(Mul(mx, mx), Mul(my, my)), zero);
    const __m512d tj = Add(Sub(Mul(Sub(x1, cx), fy1), Mul(Sub(y1, cy), fx1)), tz1);
    const __m512d mxj = Sub(x1, rx1), myj = Sub(y1, ry1);
    bfx = Select(two, Add(bfx, fx1), bfx);
    bfy = Select(two, Add(bfy, fy1), bfy);
    btq = Select(two, Add(btq, tj), btq);
    moved2 = Select(two, _mm512_max_pd(Add(Mul(mxj, mxj), Mul(myj, myj)), moved2), moved2);
    bfy = Sub(bfy, Mul(_mm512_loadu_pd(arr.bmass + b), Select(on, gv, zero)));
    _mm512_storeu_pd(arr.bfx + b, bfx);
    _mm512_storeu_pd(arr.bfy + b, bfy);
    _mm512_storeu_pd(arr.btq + b, btq);
    const __m512d inv_mass = _mm512_loadu_pd(arr.binv_mass + b), inv_inertia = _mm512_loadu_pd(arr.binv_inertia + b);
    __m512d vx = _mm512_loadu_pd(arr.bvx + b), vy = _mm512_loadu_pd(arr.bvy + b), w = _mm512_loadu_pd(arr.bw + b);
    if constexpr (kKick) {
      vx = Select(on, Add(vx, Mul(Mul(half, bfx), inv_mass)), vx);
      vy = Select(on, Add(vy, Mul(Mul(half, bfy), inv_mass)), vy);
      w = Select(on, Add(w, Mul(Mul(half, btq), inv_inertia)), w);
      _mm512_storeu_pd(arr.bvx + b, vx);
      _mm512_storeu_pd(arr.bvy + b, vy);
      _mm512_storeu_pd(arr.bw + b, w);
    }
    // OutrunsSkin
    const __m512d nvx = Add(vx, Mul(Mul(half, bfx), inv_mass));
    const __m512d nvy = Add(vy, Mul(Mul(half, bfy), inv_mass));
    const __m512d nw = Add(w, Mul(Mul(half, btq), inv_inertia));
    const __m512d reach = Sub(limit, Add(Add(Mul(dt, _mm512_sqrt_pd(Add(Mul(nvx, nvx), Mul(nvy, nvy)))),
                                             Mul(_mm512_abs_pd(Mul(dt, nw)), _mm512_loadu_pd(arr.bradius + b))),
                                         eps));
    const int runs =
        _mm512_cmp_pd_mask(reach, zero, _CMP_LE_OQ) | _mm512_cmp_pd_mask(moved2, Mul(reach, reach), _CMP_GT_OQ);
    out = static_cast<__mmask8>(out | (on & runs));
  }
  if (out != 0) *outrun = true;
  return b;
}

#undef GRANARY_AVX512

}  // namespace

int PairEntriesAvx512(int e0, int e1, const int* nl_i, const int* nl_j, const double* nl_reff, const double* nl_meff,
                      double* nl_sx, double* nl_sy, double* nl_fx, double* nl_fy, double* nl_c, const DiscKin* kin,
                      const ContactParams& pp, double dt) {
  return WithContactLaw(pp, [&](auto model, auto cap) {
    return PairEntriesImpl<decltype(model), decltype(cap)::value>(e0, e1, nl_i, nl_j, nl_reff, nl_meff, nl_sx, nl_sy,
                                                                  nl_fx, nl_fy, nl_c, kin, pp, dt);
  });
}

template <int kDiscs>
int DriftUniformAvx512(int b0, int b1, const DriftArrays& arrays, double dt, const double box[3], double limit,
                       bool* beyond, bool* moved) {
  return DriftUniformImpl<kDiscs>(b0, b1, arrays, dt, box, limit, beyond, moved);
}

int PlaceDiscsAvx512(int d0, int d1, double limit, const int* dbody, int body_end, const DriftArrays& arrays,
                     bool* moved) {
  return PlaceDiscsImpl(d0, d1, limit, dbody, body_end, arrays, moved);
}

template <bool kKick>
int BodySumsUpTo2Avx512(int b0, int b1, const BodySumArrays& arrays, int disc_end, double g, double half, double dt,
                        double limit, bool* outrun) {
  return BodySumsUpTo2Impl<kKick>(b0, b1, arrays, disc_end, g, half, dt, limit, outrun);
}

#else  // not x86-64 with GCC or Clang

bool Avx512Available() { return false; }

int PairEntriesAvx512(int e0, int, const int*, const int*, const double*, const double*, double*, double*, double*,
                      double*, double*, const DiscKin*, const ContactParams&, double) {
  return e0;
}

template <int kDiscs>
int DriftUniformAvx512(int b0, int, const DriftArrays&, double, const double[3], double, bool*, bool*) {
  return b0;
}

int PlaceDiscsAvx512(int d0, int, double, const int*, int, const DriftArrays&, bool*) { return d0; }

template <bool kKick>
int BodySumsUpTo2Avx512(int b0, int, const BodySumArrays&, int, double, double, double, double, bool*) {
  return b0;
}

#endif

template int BodySumsUpTo2Avx512<false>(int, int, const BodySumArrays&, int, double, double, double, double, bool*);
template int BodySumsUpTo2Avx512<true>(int, int, const BodySumArrays&, int, double, double, double, double, bool*);
template int DriftUniformAvx512<1>(int, int, const DriftArrays&, double, const double[3], double, bool*, bool*);
template int DriftUniformAvx512<2>(int, int, const DriftArrays&, double, const double[3], double, bool*, bool*);

}  // namespace granary::engine
