/* sonar-direct-path.h: the emissions heard straight from the emitters.
 *
 * A real sensor's microphones hear its emitters directly, a few
 * centimetres away, far louder than any echo: each emitter's waveform
 * reaches microphone j |e_n - m_j| / c after the trigger. After the
 * matched filters that sound is an "echo" at range ~0 whose range
 * sidelobes cover the first c T / 2 (1.5 m for 4000 samples at 450 kHz)
 * and whose band-limited tails (the band's sharp edges: sidelobes that
 * fall as 1 / lag) raise the whole image's floor: 31 dB at 8 m when it is
 * 44 dB over a unit reflector's echo at 1 m (tests/foreign_sim.py,
 * direct_path = 0.1), which loses objects at every range.
 *
 * Its shape is known (the waveforms, on the geometry's paths) but not its
 * gain, phase or the exact delay (transducer responses, sub-millimetre
 * geometry): per microphone, the least-squares fit of each emitter's
 * waveform through a short FIR of 2 half_taps + 1 taps centred on its
 * path's delay (every emitter at once: the normal equations of the
 * N (2 half_taps + 1) shifted waveforms, factored once here) is
 * subtracted from the ping. The taps absorb a fractional delay, a path
 * up to half_taps samples off (2.3 mm at 450 kHz for 3) and a short
 * response. The fit costs N (2 half_taps + 1) dot products of a
 * waveform's length per microphone and ping (0.5 ms of CPU for the
 * default sensor); the subtraction as much again.
 *
 * SONAR_DIRECT_PATH_AUTO subtracts it only from a microphone where it
 * explains SONAR_DIRECT_PATH_MIN_SHARE of the power recorded over the
 * samples the direct path spans (from the first emission's arrival to the
 * last one's end): echoes and noise there put about P / (b L) into such a
 * fit (P waveforms, L samples, b the band's share of the spectrum: 0.05
 * for the default sensor) and at most 0.024 on the presets and 96 foreign
 * scenes, a direct path 0.86-0.9995 (tests/foreign_sim.py, direct_path
 * 1e-4 to 1, transducer responses included). A probe, each emitter's
 * centre tap alone (N dot products instead of P), stops at half that
 * share first, so that a recording without a direct path costs N dot
 * products per microphone and is processed bit for bit as without this
 * stage.
 */
#ifndef SONAR_DIRECT_PATH_H
#define SONAR_DIRECT_PATH_H

#include "sonar-setup.h"
#include "sonar-spectrum.h"     /* SonarDirectPath, SonarDirectPathMode */

G_BEGIN_DECLS

/* Taps either side of a path's delay, by default. */
#define SONAR_DIRECT_PATH_HALF_TAPS 3
/* AUTO: the share of the power over the direct path's samples that the
 * fit must explain (the probe's stop: half of it). */
#define SONAR_DIRECT_PATH_MIN_SHARE 0.2

/* The fit of @setup's emissions to each of its microphones, @half_taps
 * either side of each path's delay. NULL with @error (SONAR_ERROR_SETTINGS)
 * when a ping is too short to hold the direct path. */
SonarDirectPath *sonar_direct_path_new (SonarSetup * setup,
    guint half_taps, GError ** error);
void sonar_direct_path_free (SonarDirectPath * dp);

/* Bytes sonar_direct_path_new () holds for @setup: a factor of
 * (N (2 half_taps + 1))^2 doubles per microphone (0.8 MB for 32
 * microphones and 8 emitters at 3). */
guint64 sonar_direct_path_memory (const SonarSetup * setup,
    guint half_taps);

/* Doubles of scratch a caller of sonar_direct_path_remove () provides
 * (one array per thread that calls it). */
gsize sonar_direct_path_scratch_size (const SonarDirectPath * dp);

/* Fits the direct path to microphone @mic's ping @signal (@length
 * samples from the trigger, contiguous) and, as @mode says, subtracts it
 * in place. Returns the power the fit explains over the rest of what the
 * microphone records over the direct path's samples, in dB (-inf for
 * silence or a ping shorter than the set-up's), whether or not it was
 * subtracted (with AUTO, possibly the probe's); *@removed (may be NULL)
 * tells which. */
double sonar_direct_path_remove (const SonarDirectPath * dp, guint mic,
    float *signal, gsize length, SonarDirectPathMode mode, double *scratch,
    gboolean * removed);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarDirectPath, sonar_direct_path_free)

G_END_DECLS

#endif
