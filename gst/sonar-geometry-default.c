/* sonar-geometry-default.c: the built-in array, so that the default scene
 * runs with no file at all.
 *
 * Microphones: the 32-microphone eRTIS layout (data/ertis-microphones.json,
 * from the Cosys-Lab Acoustic Imaging Toolbox), in the sensor frame; a test
 * checks that this table equals that file.
 *
 * Emitters: 8 emitters on an ellipse just outside the microphone aperture
 * (semi-axes 55 mm in x, 40 mm in y), at unevenly spaced angles
 * 15, 60, 110, 150, 200, 245, 290, 335 degrees from +x towards +y. Outside,
 * so the MIMO virtual array (every emitter + microphone midpoint) is about
 * twice as wide as the microphone array alone; uneven, so that the virtual
 * array has no regular spacing and hence no grating lobes.
 */
#include "sonar-setup.h"

static const double ertis_microphones[][3] = {
  { -0.0384,   0.0151, 0.0},
  { -0.0232,   0.0101, 0.0},
  { -0.0121,   0.0164, 0.0},
  { -0.0046,   0.0153, 0.0},
  { -0.0367,   0.0054, 0.0},
  { -0.0144,   0.0061, 0.0},
  {  0.0054,   0.0011, 0.0},
  {  0.0273,  -0.0027, 0.0},
  { -0.0387,   0.0001, 0.0},
  { -0.0281,   0.0002, 0.0},
  { -0.0094,  -0.0013, 0.0},
  { -0.0060,   0.0000, 0.0},
  { -0.0357,  -0.0117, 0.0},
  { -0.0318,  -0.0112, 0.0},
  { -0.0286,  -0.0166, 0.0},
  {  0.0029,  -0.0086, 0.0},
  { -0.0011,   0.0178, 0.0},
  {  0.0067,   0.0115, 0.0},
  {  0.0103,   0.0144, 0.0},
  {  0.0172,   0.0140, 0.0},
  {  0.0384,   0.0022, 0.0},
  {  0.0283,   0.0162, 0.0},
  {  0.0354,   0.0125, 0.0},
  {  0.0373,   0.0150, 0.0},
  { -0.0084,  -0.0047, 0.0},
  {  0.0107,  -0.0111, 0.0},
  {  0.0189,  -0.0166, 0.0},
  {  0.0363,  -0.0101, 0.0},
  {  0.0057,  -0.0224, 0.0},
  { -0.0036,  -0.0223, 0.0},
  {  0.0315,  -0.0161, 0.0},
  {  0.0083,  -0.0178, 0.0},
};

static const double default_emitter_angles_deg[] = {
  15.0, 60.0, 110.0, 150.0, 200.0, 245.0, 290.0, 335.0,
};

#define EMITTER_SEMI_AXIS_X 0.055
#define EMITTER_SEMI_AXIS_Y 0.040

void
sonar_geometry_init_default (SonarGeometry * geometry)
{
  const guint n_mics = G_N_ELEMENTS (ertis_microphones);
  const guint n_emitters = G_N_ELEMENTS (default_emitter_angles_deg);

  geometry->n_microphones = n_mics;
  geometry->microphones = g_new (SonarVec3, n_mics);
  for (guint j = 0; j < n_mics; j++)
    geometry->microphones[j] = sonar_vec3 (ertis_microphones[j][0],
        ertis_microphones[j][1], ertis_microphones[j][2]);

  geometry->n_emitters = n_emitters;
  geometry->emitters = g_new (SonarVec3, n_emitters);
  for (guint n = 0; n < n_emitters; n++) {
    const double a = default_emitter_angles_deg[n] * (M_PI / 180.0);
    /* Rounded to 0.1 mm, as a drawing of the sensor would give them. */
    geometry->emitters[n] = sonar_vec3 (round (EMITTER_SEMI_AXIS_X * cos (a)
            * 1e4) / 1e4, round (EMITTER_SEMI_AXIS_Y * sin (a) * 1e4) / 1e4,
        0.0);
  }
}
