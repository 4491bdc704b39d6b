/* sonar-scene.h: what the simulated sonar looks at.
 *
 * Positions and velocities are given in the world frame, whose axes are
 * those of the sensor frame (the sensor translates, it does not rotate):
 * x right, y up, z boresight, metres and m/s, at time t = 0. Everything
 * moves in straight lines at constant velocity; the air is at rest in the
 * world frame. A scene file (docs/FORMATS.md) or a built-in preset makes one.
 */
#ifndef SONAR_SCENE_H
#define SONAR_SCENE_H

#include <glib.h>
#include "sonar-vec3.h"

G_BEGIN_DECLS

#define SONAR_MAX_REFLECTORS 4096

typedef enum
{
  SONAR_REFLECTOR_POINT,
  SONAR_REFLECTOR_CYLINDER,     /* vertical (y) axis through position */
} SonarReflectorKind;

typedef struct
{
  SonarReflectorKind kind;
  SonarVec3 position;           /* world frame at t = 0, m (cylinder: axis) */
  SonarVec3 velocity;           /* world frame, m/s */
  double radius;                /* cylinder radius, m; 0 for a point */
  double strength;              /* echo amplitude factor, >= 0 */
} SonarReflector;

typedef struct
{
  guint dimensions;             /* 2: everything in the y = 0 plane; or 3 */
  SonarVec3 sensor_position;    /* world frame at t = 0, m */
  SonarVec3 sensor_velocity;    /* world frame, m/s */
  guint n_reflectors;
  SonarReflector *reflectors;
} SonarScene;

/* The built-in scenes, in the order of sonar_scene_presets ()'s table. */
typedef enum
{
  SONAR_SCENE_PRESET_DEFAULT,   /* three reflectors, one approaching */
  SONAR_SCENE_PRESET_FIG9,      /* paper Fig. 9: 4 still + 2 moving objects */
  SONAR_SCENE_PRESET_FIG10,     /* paper Fig. 10: drive at 0.3 m/s past objects */
  SONAR_SCENE_PRESET_EMPTY,     /* no reflector: noise only */
  SONAR_SCENE_PRESET_CROSSING,  /* driving past a still wall, two walkers cross */
} SonarScenePreset;

/* An object of a preset, in the horizontal plane, placed around the
 * sensor's position at t = 0 by range and azimuth, moving in the world
 * frame: radially (away from that position) and tangentially (towards
 * increasing azimuth). Presets read like the paper's figures. */
typedef struct
{
  SonarReflectorKind kind;
  double range;                 /* m, to a cylinder's surface */
  double azimuth;               /* degrees */
  double radial_velocity;       /* m/s, + = away */
  double tangential_velocity;   /* m/s */
  double radius;                /* m, cylinders; 0 for points */
  double strength;
} SonarPresetObject;

/* One entry of the table of presets: sonarsrc's "scene" enum (its nick
 * and description), the benchmark and the tests read it; a new preset is
 * one entry (and its enum value). */
typedef struct
{
  SonarScenePreset preset;
  const char *nick;
  const char *description;
  SonarVec3 sensor_velocity;    /* world frame, m/s */
  const SonarPresetObject *objects;
  guint n_objects;
} SonarScenePresetInfo;

/* The table, in enum order; *@n_presets receives its length. */
const SonarScenePresetInfo *sonar_scene_presets (guint * n_presets);

void sonar_scene_init_preset (SonarScene * scene, SonarScenePreset preset);
void sonar_scene_clear (SonarScene * scene);
void sonar_scene_copy (SonarScene * dest, const SonarScene * src);

/* Loads a scene file; on error FALSE with @error naming file and problem. */
gboolean sonar_scene_load_file (SonarScene * scene, const char *path,
    GError ** error);
/* Same, from JSON text (@origin names it in error messages). */
gboolean sonar_scene_load_data (SonarScene * scene, const char *json,
    const char *origin, GError ** error);

gboolean sonar_scene_validate (const SonarScene * scene, GError ** error);

const char *sonar_scene_preset_to_string (SonarScenePreset preset);
gboolean sonar_scene_preset_from_string (const char *name,
    SonarScenePreset * preset);
const char *sonar_reflector_kind_to_string (SonarReflectorKind kind);

G_END_DECLS

#endif /* SONAR_SCENE_H */
