/* version.h — the one version string of agglo: written into every output
 * file (output.c) and every FMU's modelDescription.xml (export.c). */
#ifndef COUPLER_VERSION_H
#define COUPLER_VERSION_H

#define AGGLO_VERSION "0.2.0"

#endif
