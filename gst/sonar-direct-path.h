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
 * waveform through an FIR of n_taps taps from SONAR_DIRECT_PATH_LEAD
 * samples before its path's delay on (every emitter at once: the normal
 * equations of the N n_taps shifted waveforms, factored once here) is
 * subtracted from the ping. The taps absorb a fractional delay, a path
 * up to the lead early (1.5 mm at 450 kHz) or the rest late, and a
 * response as long as the taps: a transducer rings after the sound
 * arrives, so the taps lie after it (an emitter's resonance of Q 1.5-3
 * that the waveforms lack: 58 of 72 foreign objects found with 7 taps,
 * 66 with 41, 68 without a direct path). The fit costs N n_taps dot
 * products of a waveform's length per microphone and ping (0.35 ms of
 * CPU for the default sensor at 7); the subtraction as much again.
 *
 * SONAR_DIRECT_PATH_AUTO subtracts it only from a microphone where it
 * explains SONAR_DIRECT_PATH_MIN_SHARE of the power recorded over the
 * samples the direct path spans (from the first emission's arrival to the
 * last one's end): echoes and noise there put about P / (b L) into such a
 * fit (P waveforms, L samples, b the band's share of the spectrum: 5 %
 * for the default sensor) and at most 2.4 % on the presets and 96 foreign
 * scenes, a direct path 86-99.95 % (tests/foreign_sim.py, direct_path
 * 1e-4 to 1, transducer responses included). A probe, each emitter's tap
 * at its path's delay alone (N dot products instead of P), stops at half
 * that share first, so that a recording without a direct path costs N
 * dot products per microphone and is processed bit for bit as without
 * this stage. dopplerbank's use of it (direct-path, direct-path-taps, its info
 * message): docs/CONTRACTS.md §1 and §10.
 */
#ifndef SONAR_DIRECT_PATH_H
#define SONAR_DIRECT_PATH_H

#include "sonar-setup.h"
#include "sonar-spectrum.h"     /* SonarDirectPath, SonarDirectPathMode */

G_BEGIN_DECLS

/* Taps of a path's filter by default, the first SONAR_DIRECT_PATH_LEAD
 * of them before its delay; at most SONAR_DIRECT_PATH_MAX_TAPS. */
#define SONAR_DIRECT_PATH_TAPS 7
#define SONAR_DIRECT_PATH_LEAD 2
#define SONAR_DIRECT_PATH_MAX_TAPS 64
/* AUTO: the share of the power over the direct path's samples that the
 * fit must explain (the probe's stop: half of it). */
#define SONAR_DIRECT_PATH_MIN_SHARE 0.2
/* An emitter that rings longer than the taps: where the fit leaves more
 * than RINGING_LEFT of what it explained over the direct path's samples
 * (-20 dB; a resonance of Q 3 the waveforms lack leaves -8 dB at 7 taps,
 * echoes and noise under a direct path 33 dB or more over a unit echo at
 * 1 m far less), and the waveforms explain what it left just past its
 * taps RINGING_F times more per column than it leaves per sample (an F
 * ratio: 0.01-0.33 without ringing, 2.7-20 with it; sonar-direct-path.c,
 * rings ()), what is left is fitted again with RINGING_TAPS taps (-41 dB
 * of that resonance); from then on, every microphone whose fit leaves
 * that much (ringing is the emitters'). Their factors (27.5 MB for 32
 * microphones and 8 emitters) are made on the first ping that needs
 * them. */
#define SONAR_DIRECT_PATH_RINGING_LEFT 0.01
#define SONAR_DIRECT_PATH_RINGING_F 1.0
#define SONAR_DIRECT_PATH_RINGING_TAPS 41

/* Taps a path needs for @setup: SONAR_DIRECT_PATH_TAPS, more as the band
 * reaches towards Nyquist. A path's delay falls between samples, and a
 * filter that delays the band by a fraction of a sample is longer the
 * narrower the band's edge below Nyquist: SONAR_DIRECT_PATH_TAPS / (1 -
 * f_high / (rate / 2)) scaled to the built-in sensor's 7 (80 kHz at 450
 * kHz): 13 at 250 kHz, 28 at 192 kHz (where 7 left half the objects of
 * foreign scenes under a direct path, 21 none). */
guint sonar_direct_path_default_taps (const SonarSetup * setup);

/* The fit of @setup's emissions to each of its microphones, @n_taps
 * taps a path. NULL with @error (SONAR_ERROR_SETTINGS) when a ping is too
 * short to hold the direct path or @n_taps is out of its range. */
SonarDirectPath *sonar_direct_path_new (SonarSetup * setup, guint n_taps,
    GError ** error);
void sonar_direct_path_free (SonarDirectPath * dp);

/* Bytes sonar_direct_path_new () holds for @setup at most: a factor of
 * (N n_taps)^2 doubles per microphone (0.8 MB for 32 microphones and 8
 * emitters at 7 taps, 27.5 MB at 41), and below RINGING_TAPS taps the
 * ringing fit's, which the emitters' ringing makes (28.3 MB at 7). */
guint64 sonar_direct_path_memory (const SonarSetup * setup, guint n_taps);

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

/* Whether a microphone's path rang past @dp's taps on some ping, and was
 * fitted again with SONAR_DIRECT_PATH_RINGING_TAPS taps. */
gboolean sonar_direct_path_rang (const SonarDirectPath * dp);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarDirectPath, sonar_direct_path_free)

G_END_DECLS

#endif
