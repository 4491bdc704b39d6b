/* sonar-velocity.h: radial velocity of each reflector from its Doppler-ACF
 * curves (paper Section III.B, eq. 15, Fig. 4f-g, 6 and 8).
 *
 * For a reflector at a centroid and for each emitter n, the single-emitter
 * (MISO) image is evaluated at every velocity of the bank, but only in a
 * small window of pixels around the centroid; its maximum over the window
 * is the emitter's Doppler-ACF value at that velocity. The N curves are
 * multiplied (summed in the log domain, so nothing underflows), and the
 * product's peak, refined below the bank's step by a parabola through the
 * log values, is the estimate. Work grows with reflectors x bank size x
 * window, never with the whole image.
 *
 * A centroid whose curves are not peaked (a sidelobe or cross-talk ghost)
 * is flagged: its normalised product has a small variance (the paper's
 * test, Fig. 8), the emitters' own peaks disagree, and the emitters'
 * outputs at the estimated velocity do not add up coherently. The
 * coherence factor |sum|^2 / (N sum |.|^2) weighs the power the N
 * emitters' outputs share against the interference measured at the pixel
 * itself, the power left in the N - 1 combinations orthogonal to their sum
 * (noise, sidelobes and the cross-talk of every other echo): an echo of
 * amplitude A in interference of power s^2 per emitter scores (A^2 +
 * s^2 / N) / (A^2 + s^2) on average, and interference alone, independent
 * across the emitters, reaches c with probability (1 - c)^(N - 1). The
 * threshold is set by that false-alarm rate (coherence_pfa): 1.3e-5 gives
 * 0.80 over 8 emitters, which an echo 16 dB above its interference in the
 * image passes 8 times in 10 and one 13 dB above 3 times in 10 (an
 * isolated echo scores above 0.9). Lower thresholds would find more of a
 * crowd, but a strong echo's cross-talk ridges reach 0.73-0.8 where
 * wardcluster's floors let their peaks through (tests/test-velocityest.c,
 * near-far; tests/test_foreign.py, split pairs). In a crowd an echo whose
 * factor falls short still passes when the power its emitters share
 * stands pooled_snr_db above the interference pooled over every pixel and
 * hypothesis the prescreen evaluated (measured with 21 or more degrees of
 * freedom instead of the pixel's 7) and the interference at its own pixel
 * is no more than twice the pooled (plus what an isolated echo's focus
 * leaves unshared): a blend of two echoes in one beam, or an alias of a
 * regular grid, has its emitters disagree at the pixel more than around
 * it. Measured: a crowd's real echoes passing so stand 14.5-17 dB above
 * the pool; the ghosts the factor keeps out 12 dB at most, but a cross-term
 * of two strong echoes at one range in a sparse scene 14.2 dB (with 8 of 8
 * emitters agreeing): the default, 16, leaves 1.8 dB over it.
 * The coherence is checked first at a few
 * Doppler hypotheses: a centroid that fails it is rejected before the bank
 * is evaluated (its estimate has a NaN velocity).
 *
 * The evaluations run on a range gate: the focused receive sum is cut to
 * the samples around the echo (the longest template, its tails and a few
 * range steps) and transformed again, a quarter of the ping's bins per
 * evaluation for the same correlations; a centroid whose members spread
 * beyond the gate is evaluated on the whole ping.
 *
 * A centroid is the energy-weighted mean of its member peaks: two echoes
 * the image resolves (objects 8 cm apart at 0.6 m, 8 degrees: four MIMO
 * beams) that wardcluster merges give a centroid between them, on
 * neither. When the estimate at a centroid of several members fails and
 * its strongest member lies 2 image steps or more from it, the estimate
 * is made again at that member's direction, and, valid there, once more
 * at the strongest direction within 2 steps of the other members'
 * weighted mean (not nearer the first than 2 steps): a second estimate of
 * the centroid. Both take every test; a centroid at its echo's peak never
 * comes this way.
 *
 * Successive cancellation (sonar_velocity_pool_estimate ()): in a crowd
 * an echo fails the tests because of its neighbours' cross-talk at its
 * own pixel. After the ping's estimates, the centroids with none valid
 * whose emitters' shared power stood pooled_snr_db above the pooled
 * interference (so 0 turns this off too) are estimated again on the
 * spectra less a model of every accepted echo: a point at its range and
 * direction, every emitter's template on its path to each microphone
 * (sonar-steering.h's delay model), its template between the two bank
 * velocities either side of its own (the two bank templates' complex
 * amplitudes fitted by least squares over every microphone and bin). In
 * rounds, each cancelling what the last accepted, until one accepts none
 * (16 at most); after the first, the failed centroids of half that
 * shared power (-3 dB) are tried too. An estimate on a residual is kept
 * only when it is one echo: along azimuth its power falls either side of
 * its direction, on at least one side, as steeply as a lone point's
 * model there (a blend of two echoes the beam does not resolve is
 * flatter on both), or when it is two (below). A ping without such a
 * centroid never comes this way and allocates nothing for it.
 *
 * Last, a stronger echo's sidelobes and cross-talk: a valid estimate 12
 * dB or more under another valid one within a pulse length (c T / 2) of
 * its range is estimated again on the spectra less the same models of
 * every other accepted echo, and stays valid only when it is found there
 * within 0.15 m/s of its velocity (a sidelobe or cross-talk goes with its
 * echo, an object stays; two such ghosts passed every test on 3-D
 * foreign recordings with air's absorption and uncalibrated microphones).
 *
 * Two echoes at one range that the beam does not resolve (8 degrees
 * apart near +-72 degrees, where it is 6.5 degrees wide) make one peak
 * between them, whose estimate passes the coherence tests as one object
 * there when nothing else is near. An estimate whose power does not fall
 * as a lone point's on both sides (on a residual, or a first estimate
 * whose coherence factor is below a lone echo's 0.95) is fitted with two
 * points: the pair at its range and velocity, one either side along
 * azimuth, whose least-squares fit to the spectra (two echo models, their
 * complex amplitudes over every microphone and bin) explains the most
 * power. When that is 1.2 times the best single point's and leaves
 * little at the estimate's own direction (a third echo between the two
 * would be left whole), each point is estimated on the spectra less the
 * other's fitted model, and both replace the estimate when each passes
 * every test, shares twice pooled_snr_db's power over the pooled
 * interference and is not a blend itself.
 *
 * Two reflectors a few centimetres apart in range share a centroid: the
 * window spans the ranges of its member peaks, so both echoes are in it,
 * and a second peak of the product that stands out of the product's floor
 * (the echoes' cross-talk) and passes the same tests is a second
 * reflector. Each then takes its own echo's range, and its velocity is
 * measured again on the window around its own echo.
 */
#ifndef SONAR_VELOCITY_H
#define SONAR_VELOCITY_H

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-image-grid.h"
#include "sonar-workers.h"

G_BEGIN_DECLS

typedef struct
{
  guint window_directions;      /* half-width of the window, in image direction steps */
  guint window_ranges;          /* half-width of the window, in image range
                                 * steps, beyond the centroid's span */
  gboolean refine;              /* parabolic sub-step refinement of the peak */
  double min_variance;          /* below: not peaked, flagged as a false positive */
  guint min_agreeing_emitters;  /* emitters whose own curve comes within 3 dB
                                 * of its maximum near the product's peak */
  double coherence_pfa;         /* the coherence test's false-alarm rate
                                 * for interference independent across
                                 * the emitters, (0, 1] */
  double min_coherence;         /* coherence factor across emitters, 0..1:
                                 * a fixed floor under coherence_pfa's
                                 * threshold */
  double pooled_snr_db;         /* dB, 0 = off: an echo whose coherence
                                 * factor falls short of coherence_pfa's
                                 * threshold (but is at least 0.5) still
                                 * passes when the power its emitters
                                 * share stands this far above the
                                 * interference pooled over the window's
                                 * pixels and hypotheses (crowds) */
  double second_peak_db;        /* a second product peak at most this far below
                                 * the first (dB per emitter, > 0) that stands
                                 * out of the product's floor and passes the
                                 * tests is a second reflector */
  guint emitters;               /* emitters whose curves enter the product and
                                 * the tests: the first k; 0 = all */
} SonarVelocityParams;

void sonar_velocity_params_init_default (SonarVelocityParams * params);

/* The coherence factor that interference independent across @n_emitters
 * emitters reaches with probability @pfa: 1 - pfa^(1 / (N - 1)); 0 for
 * one emitter (whose factor is always 1). */
double sonar_velocity_coherence_threshold (double pfa, guint n_emitters);

/* The coherence test's threshold with @params over @n_emitters:
 * coherence_pfa's, min_coherence under it. */
double sonar_velocity_params_coherence_threshold (const SonarVelocityParams
    * params, guint n_emitters);

typedef struct
{
  double range, azimuth, elevation;     /* where it was evaluated (m, degrees) */
  /* The echo's range (m), which its detection reports: at a centroid,
   * its strongest member peak's sub-pixel fit, unless the estimate took
   * an echo of its own (two in the centroid, or, with members spread
   * beyond the window, a lag more than a range step from that peak's):
   * the members' weighted mean is pulled over by the others (noise on
   * the echo's range sidelobes, a neighbour) and the window's lags are
   * whole range steps. Elsewhere (a blend's other echo, a split half)
   * where it was evaluated. */
  double echo_range;
  /* The echo's direction (degrees), which its detection reports: on a grid
   * coarser than FINE_GRID_STEP (sonar-velocity.c), the peak of a quadratic
   * fitted to the coherent strength over the 3 x 3 directions (3 on a 2-D
   * grid) half a grid step apart about the search's best (on a 3-D grid
   * along the direction cosines x and y, the array's plane: near the
   * hemisphere's rim the beam is a tilted ridge in azimuth and elevation;
   * there the patch narrows, or moves inwards, to stay in front of the
   * array), finer than the search's quarter steps and not pulled over by the
   * noise peaks a strong echo's cluster gathers; on finer grids, in the
   * pool's valid estimates (sonar_velocity_pool_estimate ()), the vertex of
   * the power the echo's model explains a quarter step either side of where
   * it was evaluated (the centroid's direction, its members' weighted mean,
   * lies 0.01-0.1 degree off a lone echo); else where it was evaluated. */
  double echo_azimuth, echo_elevation;
  /* Second derivatives of ln (amplitude) at the echo's direction, per
   * degree^2, from that fit (the emitters' coherent sum's, or the
   * model's explained power's): along azimuth, across (azimuth x
   * elevation), along elevation; NaN where no fit was made (the cross
   * and elevation terms on a 2-D grid); the model's parabolas measure no
   * cross term (0). */
  double direction_curvature[3];
  double radial_velocity;       /* m/s, + = moving away */
  guint bank_index;             /* bank velocity nearest the estimate */
  double peak_db;               /* product peak above the curve's median, dB per emitter */
  /* Second derivative of the log product (natural log of the amplitudes,
   * summed over the emitters) at its peak, per (m/s)^2: the peak's
   * sharpness, for its uncertainty (sonar-uncertainty.h); NaN when not
   * measured. */
  double velocity_curvature;
  double variance;              /* variance of the product normalised to [0, 1] */
  guint agreeing_emitters;      /* emitters whose own peak agrees */
  double coherence;             /* |sum of emitters' outputs|^2 / (N sum of
                                 * their powers) at the best window pixel */
  gboolean at_bank_edge;        /* the peak is the bank's first or last velocity */
  gboolean valid;               /* passed the false-positive tests */
  gboolean second;              /* a second reflector in the same centroid */
  /* Bank velocities whose Doppler-ACF values were evaluated (coarse pass
   * and around the peaks); 0 when the prescreen rejected the centroid. */
  guint evaluated_velocities;
} SonarVelocityEstimate;

typedef struct _SonarVelocityEstimator SonarVelocityEstimator;

/* @grid: the image the centroids come from (its steps set the window). */
SonarVelocityEstimator *sonar_velocity_estimator_new (SonarDopplerBank * bank,
    const SonarImageGrid * grid, const SonarVelocityParams * params,
    GError ** error);
void sonar_velocity_estimator_free (SonarVelocityEstimator * est);

/* Takes @params' thresholds (min_variance, min_agreeing_emitters,
 * min_coherence, second_peak_db) for the next estimate: what can change
 * between pings without allocating. The other fields must be those @est
 * was made with; FALSE with @error (SONAR_ERROR_SETTINGS) when they are
 * not, or when a value is out of range, and @est is left as it was. */
gboolean sonar_velocity_estimator_retune (SonarVelocityEstimator * est,
    const SonarVelocityParams * params, GError ** error);

/* Estimates at @centroid (its range, direction and members' span of
 * ranges; for a point, range_min = range_max = range) from @mic_spectra
 * (n_microphones x n_bins on the bank's band). Writes 1 or 2 estimates (2
 * when a second reflector of another speed shares the centroid, or a
 * blend of two echoes gives one at either's direction) and
 * returns their number. If @curves is not NULL it receives
 * the n_emitters + 1 Doppler-ACF curves in dB (emitters, then the product
 * divided by n_emitters), n_velocities each; n_emitters is params.emitters
 * when set. */
guint sonar_velocity_estimate (SonarVelocityEstimator * est,
    const SonarComplex * mic_spectra, const SonarCentroid * centroid,
    SonarVelocityEstimate * out, float *curves);

/* A centroid of a single peak at (@range m, @azimuth, @elevation
 * degrees): estimates at a known point. */
SonarCentroid sonar_velocity_point (double range, double azimuth,
    double elevation);

/* A ping's centroids are independent: a pool of estimators shares them out
 * between threads and gathers the results in centroid order, so they do
 * not depend on the number of threads. */
typedef struct _SonarVelocityPool SonarVelocityPool;

#define SONAR_VELOCITY_MAX_THREADS SONAR_MAX_WORKERS

/* @n_threads: 0 for one per processor. The threads are made here, once. */
SonarVelocityPool *sonar_velocity_pool_new (SonarDopplerBank * bank,
    const SonarImageGrid * grid, const SonarVelocityParams * params,
    guint n_threads, GError ** error);
void sonar_velocity_pool_free (SonarVelocityPool * pool);
/* sonar_velocity_estimator_retune () on every worker's estimator, between
 * estimates (not while one runs). */
gboolean sonar_velocity_pool_retune (SonarVelocityPool * pool,
    const SonarVelocityParams * params, GError ** error);

/* Estimates at every centroid: results[2 k ..] receive counts[k] (0 to 2)
 * estimates of centroid k; an echo that an earlier centroid already
 * reports (centroids millimetres apart both see it) is left out; the
 * centroids that fail, interfered at their own pixel, are estimated again
 * with the accepted echoes cancelled (above). Returns after all are done.
 * Allocates only when a ping has more centroids than any before it, and
 * on the first ping that examines an echo or cancels (the workers'
 * models). */
void sonar_velocity_pool_estimate (SonarVelocityPool * pool,
    const SonarComplex * mic_spectra, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts);

/* The spectra of the last sonar_velocity_pool_estimate () less the model
 * of every valid estimate of @results (2 per centroid, @counts[k] of
 * centroid k), each fitted as the successive cancellation fits it (above)
 * but deeper: with each template's amplitude a cubic polynomial in
 * frequency where the data show one (an F test: a real echo's spectrum
 * is the emissions' tilted by the air and the transducers, and one
 * amplitude leaves that behind; air's absorption at 4 m: -9 dB of the
 * echo in the image, against -43 dB), placed at the vertex of the power
 * its model explains along azimuth (and elevation) instead of its
 * centroid's direction (0.1 degree off a lone echo at 1 m: -28 dB of it
 * left, against -43 dB), and each microphone with its own complex gain
 * where the echo stands far enough over the noise to set it (the legs'
 * spreading across the array, an uncalibrated microphone; the gain
 * fitted over the band, shrunk towards the model's by its noise).
 * tests/test-residual.c measures each. What the ping holds under its
 * accepted echoes, into @residual (n_microphones x n_bins). Allocates
 * only on the first ping that cancels (the workers' models) and on a
 * ping with more centroids than any before, as the cancellation does. */
void sonar_velocity_pool_residual (SonarVelocityPool * pool,
    const SonarVelocityEstimate * results, const guint * counts,
    guint n_centroids, SonarComplex * residual);

/* sonar_velocity_pool_estimate () at @centroids of a residual (spectra
 * less some echoes' models, as sonar_velocity_pool_residual () makes
 * them), each valid estimate then judged as the successive cancellation
 * judges its own on a residual: kept when it is one echo (its beam falls
 * as a lone point's on at least one side), or two when a fit of two
 * points finds them. */
void sonar_velocity_pool_estimate_residual (SonarVelocityPool * pool,
    const SonarComplex * residual, const SonarCentroid * centroids,
    guint n_centroids, SonarVelocityEstimate * results, guint * counts);

/* What one centroid costs the pool's estimators, for sonar-bench's
 * arithmetic floor. A focus (one per direction of the prescreen's search)
 * is a receive sum over the band and, with a range gate, an inverse
 * transform of gate_inverse points and a forward one of gate_forward; a
 * bank evaluation (per emitter and window direction) is a dot product
 * over @bins bins, then sums over blocks of @block bins per lag read. */
typedef struct
{
  guint bins, block;
  guint gate_inverse, gate_forward;     /* 0 without a gate */
  guint directions;             /* searched by the prescreen */
  guint screens;                /* the prescreen's evaluations over them */
} SonarVelocityWork;

void sonar_velocity_pool_work (const SonarVelocityPool * pool,
    SonarVelocityWork * work);

/* The echoes the last sonar_velocity_pool_estimate () examined as
 * possible blends of two unresolved echoes (one estimate, less coherent
 * than a lone echo's): a crowd's work beyond its bank evaluations, which
 * the workers share as they share the centroids. */
guint sonar_velocity_pool_last_examined (const SonarVelocityPool * pool);

/* The echo models the last sonar_velocity_pool_estimate ()'s checks for
 * blends of two echoes reused instead of making them again. Tests: with
 * sonar_velocity_pool_check_models (), each is also made again, and
 * counted only when the one reused is the same bit for bit. */
guint sonar_velocity_pool_last_reused (const SonarVelocityPool * pool);
void sonar_velocity_pool_check_models (SonarVelocityPool * pool,
    gboolean check);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarVelocityEstimator,
    sonar_velocity_estimator_free)
G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarVelocityPool, sonar_velocity_pool_free)

/* When a detection holds: its radial velocity is measured over the whole
 * echo, so it holds when the emissions' energy centre (@emission_centre s
 * after the trigger, sonar_setup_emission_centre ()) reaches the object;
 * its imaged @range (m) is the object's when the wave leaving the array at
 * the trigger reached it. Returns the range at the later instant (moved on
 * at @radial_velocity, m/s) and sets *@delay to that instant, in seconds
 * after the trigger: the wave leaving at the trigger reaches the object
 * after range / c, the energy centre emission_centre / (1 - v / c) later. */
double sonar_velocity_centre_range (double range, double radial_velocity,
    double speed_of_sound, double emission_centre, double *delay);

/* Whether @radial_velocity (m/s) approaches the sensor: by 0.005 m/s or
 * more, what reads -0.01 or less at the hundredth (sonarviz's labels). A
 * still object's estimate lies a few mm/s either side of 0: it is not
 * approaching (the paper's Fig. 9 marks approaching objects, and still or
 * fleeing ones alike). FALSE for NaN. */
gboolean sonar_velocity_approaching (double radial_velocity);

G_END_DECLS

#endif
