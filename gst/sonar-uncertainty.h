/* sonar-uncertainty.h: how well a detection is known, from the ping's own
 * data: the echo's amplitude, its signal-to-noise ratio, and the 1-sigma
 * uncertainty of its range, direction and radial velocity.
 *
 * Each coordinate is the peak of a curve (the image's envelope along range,
 * azimuth and elevation; the Doppler-ACF product along velocity). For a
 * peak of shape A rho(x - x0) in noise whose correlation has the same
 * shape (the matched filter's, the delay-and-sum beam's), linearising
 * the peak condition gives the Cramér-Rao bound
 *
 *   sigma_x^2 = 1 / (2 SNR |kappa|),
 *
 * SNR = A^2 / E|n|^2 (noise power per pixel, one hypothesis), kappa the
 * second derivative of ln |rho| at the peak, both measured on the data:
 * kappa from the three log samples around the image's peak (per m^2, per
 * degree^2) and from a least-squares parabola through the log product
 * (per (m/s)^2, summed over the N emitters' curves, each with 1/N of the
 * MIMO image's SNR: sigma_v^2 = N / (2 SNR |K|)).
 *
 * The noise: the image's noise is flat over range (white noise at the
 * microphones, through the same filters everywhere), and echoes fill few
 * pixels: per block of SONAR_UNCERTAINTY_NOISE_BLOCK of range, the lower
 * quartile over its positive pixels (every direction); of the blocks'
 * quartiles, the one with a tenth of them below it (echoes only add
 * power, and an echo's cross-talk through the other emitters' templates
 * lifts every direction within a pulse length of it: with objects spread
 * over a short window that is most blocks), read as the quartile of the
 * maximum of K_eff independent Rayleigh envelopes:
 * E|n|^2 = 2 s^2 = q^2 / -ln (1 - 4^(-1/K)), with
 * K_eff = 1 + (K - 1) SONAR_UNCERTAINTY_QUARTILE_SHARE for an image over
 * K Doppler hypotheses (neighbouring hypotheses are correlated: fewer
 * count at the quartile than at wardcluster's 1e-10 tail). Not the
 * range bin's own quartile, as wardcluster's CFAR takes: at high SNR it
 * holds the echo's own sidelobes.
 *
 * No floor term: over 8 places x 12 noise seeds (sonar-bench --sweep
 * uncertainty) the scatter kept falling as 1 / sqrt (SNR) down to the
 * highest SNR measured (44 dB in the image); the grid's interpolation
 * bias is fixed per place, a bias, which these sigmas leave out; so is
 * the other echoes' cross-talk at a detection's range, fixed by the
 * scene's geometry. Every ratio of reported sigma to scatter is
 * 0.97-1.05 from 15 to 44 dB of image SNR (with the median block the
 * echo's own cross-talk lifted the noise read above 40 dB: 1.3-1.4).
 *
 * On a 3-D image (2 degree grid, the hemisphere) the same sigmas, with
 * the direction wardcluster blends from the 3 x 3 fits around its peak's
 * 2 x 2 block, read 0.87-1.06 of the scatter for every coordinate over
 * 36 still points at random directions, 22.7-31.2 dB of image SNR
 * (tools/uncertainty-3d.py --seeds 1 2 3; README, Robot-ready results).
 * There a still point's peak has the virtual array's beam shape, the
 * noise's correlation between directions is that beam too, and on a
 * one-hypothesis image the parabola's scatter is the linear propagation
 * of that noise (sonar_uncertainty_parabola_sigma ()); on the detection
 * image the maximum over the hypotheses changes the samples' noise,
 * which K_eff, calibrated with this bound on the 2-D scatter, absorbs.
 * Where velocityest fitted the direction (on grids coarser than a
 * degree: the 3 x 3 of its coherent sums half a grid step apart; on
 * finer ones the power each valid echo's model explains a quarter step
 * either side, along each axis; see SonarVelocityEstimate), the
 * detection's direction is that fit's vertex,
 * and its sigmas the marginals of the covariance (2 g SNR (-K))^-1 of the
 * fit's Hessian K of ln (amplitude) per degree^2 (the tilted beam's cross
 * term widens them by 1 / (1 - rho^2)), with the fit's SNR gain g
 * (SONAR_UNCERTAINTY_FIT_SNR_GAIN). On a 3-D grid the fit is made along
 * the direction cosines and K is J^T K_u J, J their derivatives per
 * degree: near the rim, where a degree of azimuth moves the beam little,
 * the azimuth's sigma grows as it should. A bias of about 0.0013 in the
 * cosines (0.07 degree at boresight; tools/direction-errors-3d.py) is
 * left out, as the grid's is above: near the rim it is degrees of
 * azimuth (0.57 rms, 1.8 at worst 70-88 degrees off boresight). */
#ifndef SONAR_UNCERTAINTY_H
#define SONAR_UNCERTAINTY_H

#include <glib.h>

#include "sonar-cluster.h"
#include "sonar-image-grid.h"
#include "sonar-velocity.h"

G_BEGIN_DECLS

typedef struct
{
  double amplitude_db;          /* 20 log10 of the image's envelope at the peak */
  double snr_db;                /* 10 log10 (A^2 / E|n|^2) */
  double range_sigma;           /* m */
  double azimuth_sigma;         /* degrees */
  double elevation_sigma;       /* degrees; NaN on a 2-D image (one elevation) */
  double radial_velocity_sigma; /* m/s; NaN without a velocity curvature */
} SonarUncertainty;

/* m of range per block of the noise's quartiles. */
#define SONAR_UNCERTAINTY_NOISE_BLOCK 0.25

/* Effective independent hypotheses per further one at the noise's
 * quartile: with wardcluster's tail value (0.87, sonar-cluster.h) every
 * sigma came out 0.82-0.85 of the measured scatter at every SNR from -30
 * to -20 dB per channel (sonar-bench --sweep uncertainty, 8 places x 12
 * seeds, 47 hypotheses): the noise 1.45 times too low, which K_eff = 14
 * (not 41) at the quartile gives: (14 - 1) / 46. */
#define SONAR_UNCERTAINTY_QUARTILE_SHARE 0.28

/* g: each emitter's Doppler-ACF curve carries g / N of the MIMO image's
 * SNR (g = 1 if the N emitters' noises added up independently in the
 * image). Measured: with g = 1 the reported velocity sigma was 1.52-1.56
 * times the scatter over 50 noise seeds at -30, -24 and -15 dB per
 * channel, while range and azimuth were within 8-24 % (sonar-bench
 * --sweep uncertainty): 1.54^2. */
#define SONAR_UNCERTAINTY_EMITTER_SNR_GAIN 2.4

/* The SNR velocityest's direction fit sees, over the image's (its
 * sigmas: sonar_uncertainty_measure ()). The fit reads the emitters'
 * coherent sum at the detection's own hypotheses, where the noise is one
 * hypothesis' and the meter's E|n|^2, K_eff's (above), is set for the
 * image's maximum over all of them (K_eff 14 where 41 count at the
 * quartile's tail: 1.44 of the power). Measured (tools/uncertainty-3d.py,
 * seed 1's 12 points, 24 pings): with a gain of 1 the fit's sigmas read
 * 1.3-1.6 times their scatter at 31 and 23 dB of image SNR, 1.16 and
 * 1.44 at 21 dB. The same gain fits the model's parabolas on the 2-D
 * fan (sonar-bench --sweep uncertainty: ratios 0.88-1.00 over 15-44 dB
 * of image SNR). */
#define SONAR_UNCERTAINTY_FIT_SNR_GAIN 2.0

/* The image's noise (above): its scratch is sized once for a grid, so
 * that a ping allocates nothing. */
typedef struct _SonarNoiseMeter SonarNoiseMeter;

/* For images laid out as @grid says, each pixel the maximum of
 * @hypotheses Doppler hypotheses. */
SonarNoiseMeter *sonar_noise_meter_new (const SonarImageGrid * grid,
    guint hypotheses);
void sonar_noise_meter_free (SonarNoiseMeter * meter);

/* Noise power E|n|^2 per pixel of one hypothesis' envelope in @image,
 * once per image. 0 when nothing is there to read. */
double sonar_noise_meter_power (SonarNoiseMeter * meter, const float *image);

/* Second derivative, per step^2, of the least-squares parabola through
 * @values[p - half .. p + half] (clipped to 0 .. @n - 1); NaN with fewer
 * than three values. */
double sonar_uncertainty_curvature (const double *values, guint n, guint p,
    guint half);

/* 1-sigma, in grid steps, of the sub-step offset that wardcluster reads
 * off three log samples @y (y-, y0, y+, natural log of the envelope):
 * u = (y- - y+) / (2 (y- - 2 y0 + y+)), linearised (du = w . dy,
 * w = (1 - 2u, 4u, -(1 + 2u)) / (2 (y- - 2 y0 + y+))) for noise of
 * variance @var[k] on sample k, correlation @rho1 between neighbours and
 * @rho2 between the outer two: sqrt (w^T C w). For an envelope A_k + n_k
 * in circular noise of power E|n|^2, var[k] = E|n|^2 / (2 A_k^2). NaN
 * where the samples are no peak. */
double sonar_uncertainty_parabola_sigma (const double y[3],
    const double var[3], double rho1, double rho2);

/* Fills @out for an estimate @e at @centroid of @image: @noise_power from
 * sonar_noise_meter_power (), @n_emitters the curves in e's
 * product. */
void sonar_uncertainty_measure (const float *image,
    const SonarImageGrid * grid, double noise_power,
    const SonarCentroid * centroid, const SonarVelocityEstimate * e,
    guint n_emitters, SonarUncertainty * out);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarNoiseMeter, sonar_noise_meter_free)

G_END_DECLS

#endif
