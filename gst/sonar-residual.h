/* sonar-residual.h: echoes hidden under stronger ones, found again on
 * what a ping holds under its accepted echoes (velocityest's last step).
 *
 * Within a pulse length (c T / 2, 1.5 m) of a strong echo, its cross-talk
 * through the other emitters' templates covers the image with a
 * noise-like ridge about 20 dB below it, at every direction its
 * sidelobes reach (physics notes; README, near-far: the image alone
 * keeps a dynamic range of 10 dB within the pulse, this search 20 dB).
 * An echo 10-30 dB weaker there makes no
 * peak of its own, whatever wardcluster's thresholds: on 48 foreign
 * scenes of 6 objects over 30 dB, 12 of 288 objects had no centroid, and
 * each was found on a recording of the missed objects alone.
 *
 * After a ping's estimates (sonar_velocity_pool_estimate ()), the search
 * cancels every accepted echo from the spectra (its model as the
 * successive cancellation fits it, sonar_velocity_pool_residual ()),
 * images the residual as mimobeamform does at its defaults (detection
 * hypotheses sonar_setup_hypothesis_spacing () apart, coarse to fine) on
 * the ping's own grid, clusters it as wardcluster does at its defaults,
 * and estimates at each centroid that is not an accepted echo's residue
 * (below), with every test of the first estimates (and their successive
 * cancellation among themselves), each estimate then judged as the
 * cancellation rounds judge theirs on a residual: one echo, or two
 * (sonar_velocity_pool_estimate_residual ()).
 *
 * A model leaves a little of its echo: a residue at the echo's range and
 * velocity, as two lobes 1.5-2.2 degrees either side of its direction (a
 * difference pattern: the model's direction or amplitude across the
 * array slightly off), coherent across the emitters like an echo: 15-25
 * dB under the echo while the models took their centroids' directions
 * and one gain over the array, 40-70 dB under a lone one since their own
 * direction and each microphone's gain (sonar_velocity_pool_residual ()),
 * less deep in a crowd, whose neighbours the fits see too. A centroid or
 * estimate within an accepted echo's resolution cell
 * (SONAR_RESIDUE_RANGE in range, direction cosines within
 * SONAR_RESIDUE_DIRECTION, and, once estimated, a radial velocity within
 * SONAR_RESIDUE_VELOCITY) is such a residue, and is dropped: a second
 * object there, at the same range and speed within a few degrees, is one
 * the beam and the Doppler-ACF do not resolve anyway.
 * What else a cancellation leaves (the cancelled echoes' cross-talk,
 * where their models are off) can pass the tests as an echo; such debris
 * had 6 of 8 emitters agreeing, every echo found on a residual 8 of 8
 * (13 on the foreign scenes, 15 on sonar-bench's near-far pairs), and
 * once the residual's models took the echoes' spectral shapes, 7 of 8
 * (a false object at 0.84 m, +4.5 m/s, in 1 of 320 pings of
 * tests/test-live.c's near scene): an estimate of the search counts only
 * when every emitter in the product agrees.
 *
 * Work: a ping with no accepted echo costs nothing; else one more image
 * (its coarse pass, and refinement where the residual holds something)
 * and clustering, and the estimates at the new centroids. Memory: the
 * residual spectra and one image (sonar_residual_search_memory ()).
 */
#ifndef SONAR_RESIDUAL_H
#define SONAR_RESIDUAL_H

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-image-grid.h"
#include "sonar-imager.h"
#include "sonar-setup.h"
#include "sonar-velocity.h"

G_BEGIN_DECLS

/* The resolution cell of an accepted echo whose centroids and estimates
 * are its residue: m of range (the waveform's range main lobe is 2.7 mm
 * at -3 dB; the residues measured lay within 9 mm), the distance between
 * unit direction vectors in the array's plane, x and y (0.09: 5 degrees
 * at broadside, wider towards +-90 degrees as the beam is; the residues
 * lay 1.5-2.2 degrees off at broadside, 5-8 degrees near 80), and
 * m/s of radial velocity (half a Doppler main lobe, c / (2 f0 T) = 0.33
 * m/s at -3 dB; the residues lay within 0.06). */
#define SONAR_RESIDUE_RANGE 0.02
#define SONAR_RESIDUE_DIRECTION 0.09
#define SONAR_RESIDUE_VELOCITY 0.15

/* Centroids of the residual image kept, the strongest. */
#define SONAR_RESIDUAL_MAX_CENTROIDS 256

typedef struct _SonarResidualSearch SonarResidualSearch;

/* Bytes a search on @grid for @setup's microphones on @band holds: the
 * residual spectra and its image. */
guint64 sonar_residual_search_memory (const SonarSetup * setup,
    const SonarBand * band, const SonarImageGrid * grid);

/* A search on the images of @grid (the energyscape's: its imager is made
 * with that grid, the other settings mimobeamform's defaults for it);
 * @bank the ping's Doppler bank, @n_emitters those in the velocity
 * product (SonarVelocityParams.emitters, or all). NULL with
 * @error when the imager cannot make that grid again. */
SonarResidualSearch *sonar_residual_search_new (SonarSetup * setup,
    const SonarBand * band, SonarDopplerBank * bank,
    const SonarImageGrid * grid, guint n_emitters, GError ** error);
void sonar_residual_search_free (SonarResidualSearch * search);

/* After sonar_velocity_pool_estimate (@pool, spectra, centroids,
 * @n_centroids, @results, @counts): searches the ping less its valid
 * estimates (above) and returns the number of new centroids; their
 * estimates, 2 per centroid as the pool writes them (counts[k] each), in
 * *@new_results and *@new_counts, and the centroids in *@new_centroids
 * (the search's own: not in the ping's centroids). An estimate that is a
 * residue is marked invalid; velocityest reports the valid ones alone
 * (keep-rejected or not). Allocates nothing but what the pool does: its
 * cancellation's models the first time, its centroids' results when a
 * call brings more than any before. */
guint sonar_residual_search_process (SonarResidualSearch * search,
    SonarVelocityPool * pool, guint n_centroids,
    const SonarVelocityEstimate * results, const guint * counts,
    const SonarCentroid ** new_centroids,
    const SonarVelocityEstimate ** new_results, const guint ** new_counts);

/* The imager of @search's residual images: the energyscape's grid, and
 * mimobeamform's default coarse spacing for that grid
 * (sonar_imager_params_fit_beam ()). */
const SonarImager *sonar_residual_search_imager (const SonarResidualSearch *
    search);

/* The work of the last process (): its image's units and passes
 * (sonar_imager_last_work (); 0 when it imaged nothing) and the centroids
 * it estimated. */
void sonar_residual_search_last_work (const SonarResidualSearch * search,
    guint * units, guint * passes, guint * estimated);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarResidualSearch,
    sonar_residual_search_free)

G_END_DECLS

#endif
