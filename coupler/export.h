/* export.h — `coupler export`: write the scene's FMUs (fluid.fmu, rigid.fmu). */
#ifndef COUPLER_EXPORT_H
#define COUPLER_EXPORT_H

#include "../common/scene.h"

/* Writes DIR/fluid.fmu and, when the scene has free bodies, DIR/rigid.fmu:
 * modelDescription.xml generated from the scene, the shared library from
 * lib_dir (build/fmu) and resources/scene.yaml (scene->text). Every check
 * (DIR writable, libraries readable, descriptions built) runs before the
 * first byte is written. verbose: print one line per FMU written. Returns 0
 * on success, 1 on failure (logged). */
int export_fmus(const scene_t *scene, const char *dir, const char *lib_dir, int verbose, const log_t *log);

#endif
