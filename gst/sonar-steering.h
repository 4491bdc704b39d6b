/* sonar-steering.h: the array's delay model and the steering sums on the
 * band, the one definition the imager (sonar-imager.c) and the velocity
 * stage (sonar-velocity.c) both use.
 *
 * The delay model. The array centre is the origin. A reflector at the
 * point p, range r = |p|, moving at radial velocity v (a Doppler
 * hypothesis), returns what emitter n (at E_n) sends to microphone j (at
 * M_j) later than an echo from the centre to p and back, by
 *
 *   tau_nj = (e_n / alpha + m_j) / c,   e_n = |p - E_n| - r,
 *                                       m_j = |p - M_j| - r,
 *   alpha = (c - v) / (c + v).
 *
 * e_n and m_j are the legs. A moving reflector meets each emitter's pulse
 * at a slightly different instant, which stretches the emitter leg by
 * 1 / alpha (the wideband Doppler scale of the paper's templates): a 7 m/s
 * mover then stays at its true azimuth. The legs are exact at p, so a
 * caller focuses where it evaluates them: the imager at the focus range of
 * each range zone (near field: the array is within a few metres of what
 * it sees), the velocity stage at the centroid's own point.
 *
 * The steering sums. On the band, bin k (frequency f_k = f_0 + k df), a
 * path of d metres is the phase (k0 + k dk) d, k0 = 2 pi f_0 / c,
 * dk = 2 pi df / c. Delays of emitters and microphones add, so the
 * delay-and-sum of the N x J matched filter outputs factors into a receive
 * sum over the microphones (spectra X_j) times a transmit sum over the
 * emitters (templates S_n of the hypothesis):
 *
 *   R(k) = sum_j X_j(k) exp(i (k0 + k dk) m_j),
 *   T(k) = sum_n conj (S_n(k)) exp(i (k0 + k dk) e_n / alpha),
 *
 * J + N products per bin instead of N J. The inverse transform of R T is
 * the output at every lag (the imager); emitter n's own output at the lag
 * of range r is one dot product, sum_k R(k) conj (S_n(k)) exp(i (k0 +
 * k dk) (2 r + e_n / alpha)) (the velocity stage, by blocks of bins).
 * The sums run on the kernels of sonar-kernels.h, hence on the best
 * implementation the CPU has.
 */
#ifndef SONAR_STEERING_H
#define SONAR_STEERING_H

#include "sonar-setup.h"
#include "sonar-spectrum.h"
#include "sonar-vec3.h"

G_BEGIN_DECLS

typedef struct
{
  const SonarGeometry *geometry;        /* the set-up's, borrowed */
  double speed_of_sound;        /* c, m/s */
  guint n_bins;                 /* of the band */
  double k0, dk;                /* rad per metre of path: at the band's
                                 * first bin, per bin */
} SonarSteering;

/* Steering of @setup's array on @band; borrows @setup's geometry, which
 * must outlive it. */
void sonar_steering_init (SonarSteering * steering, const SonarSetup * setup,
    const SonarBand * band);

/* The legs of the point @range m along the unit vector @direction: m_j of
 * every microphone into @mic_legs, e_n of every emitter into
 * @emitter_legs (either may be NULL). */
void sonar_steering_legs (const SonarSteering * steering,
    SonarVec3 direction, double range, double *mic_legs,
    double *emitter_legs);

/* 1 / alpha = (c + v) / (c - v): the emitter legs' stretch for a
 * reflector at radial velocity @velocity (m/s). */
double sonar_steering_stretch (const SonarSteering * steering,
    double velocity);

/* R(k) of @mic_spectra (n_microphones x n_bins) into @receive_re, _im
 * (n_bins each). */
void sonar_steering_receive_sum (const SonarSteering * steering,
    const SonarSplitSpectra * mic_spectra, const double *mic_legs,
    float *receive_re, float *receive_im);

/* T(k) of emitters @first to @end - 1, @templates (n_emitters x n_bins)
 * stretched by @stretch, into @transmit_re, _im (n_bins each). */
void sonar_steering_transmit_sum (const SonarSteering * steering,
    const SonarSplitSpectra * templates, const double *emitter_legs,
    double stretch, guint first, guint end, float *transmit_re,
    float *transmit_im);

/* The receive sum on part of the band, bins @first to @first + @n - 1 (a
 * sub-band: the imager's coarse pass), into @n values each: bit for bit
 * what the whole band's sum holds there, but for the phase ramps'
 * rounding (tests/test-steering.c). */
void sonar_steering_receive_sum_part (const SonarSteering * steering,
    const SonarSplitSpectra * mic_spectra, const double *mic_legs,
    guint first, guint n, float *receive_re, float *receive_im);
/* Emitter @emitter's output, for the receive sum @receive_re, _im and
 * @templates stretched by @stretch, at the lag of range @range, as partial
 * sums over blocks of @block bins (sonar_kernel_steer_block_sums_conj ())
 * into @blocks (ceil (n_bins / block) of them). */
void sonar_steering_emitter_blocks (const SonarSteering * steering,
    const float *receive_re, const float *receive_im,
    const SonarSplitSpectra * templates, guint emitter, double emitter_leg,
    double stretch, double range, guint block, SonarComplex * blocks);

/* sonar_steering_emitter_blocks () by blocks of 8 bins, the receive sum
 * and each emitter's template in the block8 layout
 * (sonar_kernel_block8_sums_conj ()), SONAR_BLOCK8_PADDED (n_bins) bins
 * each: writes that over 8 blocks, those past the data zero. */
void sonar_steering_emitter_blocks8 (const SonarSteering * steering,
    const float *receive_re, const float *receive_im,
    const SonarSplitSpectra * templates, guint emitter, double emitter_leg,
    double stretch, double range, SonarComplex * blocks);

/* The output of sonar_steering_emitter_blocks ()'s @blocks at the lag of
 * @offset m further in range, each block's phase taken at its centre bin:
 * over a block, the extra phase of a lag two range bins away turns by
 * 0.06 rad, an error of -60 dB (tests/test-kernels.c), so a window's lags
 * cost one pass over the bins. */
SonarComplex sonar_steering_blocks_at (const SonarSteering * steering,
    const SonarComplex * blocks, guint block, double offset);

/* ceil (n_bins / @block): the blocks of sonar_steering_emitter_blocks (). */
guint sonar_steering_n_blocks (const SonarSteering * steering, guint block);

/* sonar_steering_blocks_at () in two steps: the phasors of its lag
 * @offset into @re and @im (sonar_steering_n_blocks () each), then the
 * sums of @blocks on @n_tables such tables (re[t], im[t]) into out[t],
 * bit for bit the same outputs. The phasors depend on the offset alone: a
 * caller that reads the same offsets on many blocks makes them once
 * (sonar_kernel_steer_phasors ()), and the sums of one set of blocks at
 * several offsets run together (sonar_kernel_steer_sums_phasors ()). */
void sonar_steering_blocks_phasors (const SonarSteering * steering,
    guint block, double offset, float *re, float *im);
void sonar_steering_blocks_sums (const SonarSteering * steering,
    const SonarComplex * blocks, guint block, const float *const *re,
    const float *const *im, guint n_tables, SonarComplex * out);

/* A Doppler hypothesis's transmit sum from the zero-velocity one. The
 * templates are the emissions time-scaled by alpha and weighted by
 * sqrt (alpha) (sonar-doppler-bank.h), so with s = 1 / alpha their
 * spectra are sqrt (s) S_n(s k), and the stretched legs turn by the same
 * scaled frequency:
 *
 *   T(k) = sqrt (s) U(s k),   U(kappa) = sum_n conj (S_n(kappa)) exp(i kappa e_n),
 *
 * kappa in rad per metre of path. U is made once per direction and zone,
 * on the FFT's own grid, over the window of it that the call's
 * hypotheses read; each hypothesis then reads it at s k, one 6-point
 * interpolation per bin (sonar_kernel_scaled_product ()) instead of a
 * sum over the emitters, and its product with the receive sum is the
 * same kernel. What is interpolated is U with the phase ramp of the
 * emissions' centre taken out, V = U exp(-i kappa c0): V's transform
 * spans half an emission either side of zero, a fifth of the FFT's
 * length or less, so the interpolation is within -70 dB of the exact
 * sum (tests/test-steering.c). The hypotheses' own templates are not
 * read: only their velocities. */
typedef struct _SonarScaledTransmit SonarScaledTransmit;

/* The emissions of @setup on the FFT grid of @band (every bin to
 * Nyquist); borrows @steering, which must outlive it. */
SonarScaledTransmit *sonar_scaled_transmit_new (const SonarSteering *
    steering, const SonarSetup * setup, const SonarBand * band);
void sonar_scaled_transmit_free (SonarScaledTransmit * transmit);

/* The window of FFT bins, @first (may be negative: zeros there) and @n,
 * that hypotheses of stretches up to @stretch_max read: it starts where
 * the slowest stretch a bank allows reads, whatever the call, so that the
 * table's values, hence the image, do not depend on which other
 * hypotheses a call images. */
void sonar_scaled_transmit_window (const SonarScaledTransmit * transmit,
    double stretch_max, int *first, guint * n);
/* The longest window, of the stretches of every velocity |v| < c / 4 that
 * a Doppler bank allows: the table's size to allocate once. */
guint sonar_scaled_transmit_max_window (const SonarScaledTransmit *
    transmit);

/* V of emitters @first_emitter to @end_emitter - 1 with @emitter_legs,
 * over the window (@first, @n) into @v_re, _im (@n each). */
void sonar_scaled_transmit_table (const SonarScaledTransmit * transmit,
    const double *emitter_legs, guint first_emitter, guint end_emitter,
    int first, guint n, float *v_re, float *v_im);

/* R(k) T(k) for the hypothesis of @stretch, bins @first to @first + @n -
 * 1 of the band (@receive_re, _im and @out hold those @n), T read from
 * the table @v_re, _im of the window starting at @window_first (which
 * must hold @stretch's). */
void sonar_scaled_transmit_product (const SonarScaledTransmit * transmit,
    const float *v_re, const float *v_im, int window_first, double stretch,
    const float *receive_re, const float *receive_im, guint first, guint n,
    SonarComplex * out);

/* What an image grid of @azimuth_step degrees loses between its
 * directions (and of @elevation_step too, when above 0): how far below
 * its own peak, in dB, a still point halfway between two directions (at
 * the centre of a cell of four) is imaged at the directions around it.
 * At boresight, where the beam is narrowest (off it a degree of azimuth
 * is a smaller step of the direction cosine): the far-field MIMO beam of
 * the emissions, each emitter's echo weighted by its power spectrum over
 * the band, at the lag where the envelope peaks. The default eRTIS
 * sensor: 0.6, 2.6, 5.9, 10.5 dB for 1, 2, 3, 4 degrees of azimuth, 3.7
 * dB at the centre of a 3-D 2-degree cell. The delay-and-sum of the
 * point's echoes loses up to 0.6 dB less: the emitters' cross-talk,
 * left out here, fills the beam's flanks a little (tests/test-steering.c;
 * sonar-bench --sweep scalloping images a point at 2 m). */
double sonar_scaled_transmit_sampling_loss (const SonarScaledTransmit *
    transmit, double azimuth_step, double elevation_step);

/* The factor f <= 1 of both steps at which they lose @loss_db
 * (sonar_scaled_transmit_sampling_loss ()); 1 when they lose no more. */
double sonar_scaled_transmit_step_factor (const SonarScaledTransmit *
    transmit, double azimuth_step, double elevation_step, double loss_db);

/* The width of the MIMO beam's main lobe along azimuth (or, when
 * @elevation, along elevation), degrees: the step of a grid along that
 * axis whose point halfway between two directions loses 6 dB at
 * boresight (sonar_scaled_transmit_sampling_loss ()). The default eRTIS
 * sensor: 3.03 degrees along azimuth. At most @at_most. */
double sonar_scaled_transmit_lobe_width (const SonarScaledTransmit *
    transmit, gboolean elevation, double at_most);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarScaledTransmit, sonar_scaled_transmit_free)

G_END_DECLS

#endif
