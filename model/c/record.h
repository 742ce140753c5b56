/* Recorded ground motions read from a plain-text record file.
 *
 * File format (docs/records.md): one sample per line,
 *
 *     time  horizontal-acceleration  [vertical-acceleration]
 *
 * in s and m/s^2 (positive: ground towards +x, and upwards), separated by
 * spaces and tabs, or by one comma or semicolon (with or without spaces
 * around it), one way within a line. Lines end with LF, CR LF or CR. Lines
 * whose first non-blank character is '#' are comments; blank lines are
 * skipped. Every data line has the same number of values (2 or 3); time
 * increases strictly. Numbers are read with '.' as the decimal point whatever
 * the process's locale.
 *
 * The model interpolates the samples linearly in time and takes the ground
 * acceleration as zero before the first sample and after the last one.
 */
#ifndef ROCKING_RECORD_H
#define ROCKING_RECORD_H

#include <stddef.h>

/* Limits of what is accepted as a record (anything beyond is refused as a
 * likely mistake: wrong units, wrong column, a file that is not a record). */
#define RECORD_MAX_SAMPLES 10000000
#define RECORD_MIN_INTERVAL 1e-6    /* s */
#define RECORD_MAX_INTERVAL 100.0   /* s */
#define RECORD_MAX_TIME 1e6         /* s, largest |time| */
#define RECORD_MAX_ACCELERATION 98.0665 /* m/s^2, 10 g exactly */

typedef struct {
    int n;             /* number of samples (>= 2 once read) */
    int vertical;      /* the file has a vertical column */
    double *t;         /* sample times, s, strictly increasing */
    double *ah;        /* horizontal ground acceleration, m/s^2 */
    double *av;        /* vertical ground acceleration, m/s^2 (NULL without the column) */
    unsigned long long hash; /* FNV-1a of the samples: identifies the content */
    double peak;             /* largest |ah| and |av|, m/s^2 */
} Record;

typedef void *(*RecordAlloc)(size_t n, size_t size); /* zeroed memory, like calloc */
typedef void (*RecordFree)(void *p);

/* Read the record file at path into r (which must be empty). On failure r
 * stays empty and msg holds one line naming the file and, where it applies,
 * the line: "record file 'PATH', line N: REASON". Returns 0 on success. */
int record_read(const char *path, Record *r, RecordAlloc alloc, RecordFree release, char *msg, size_t n);

/* Release the arrays of r and leave it empty. */
void record_free(Record *r, RecordFree release);

/* Absolute path of a record file named by the parameter excitation.file:
 * file itself when it is absolute, else file relative to resourceDir (the
 * FMU's resources/ folder, may be NULL). Returns 0, or nonzero with a
 * one-line reason in msg. */
int record_path(const char *file, const char *resourceDir, char *out, size_t outLen, char *msg, size_t n);

/* A path that does not depend on a folder: /x, \\x, C:/x or C:\\x. */
int record_is_absolute(const char *path);

/* The local folder of an FMI resource location URI ("file:///C:/x/resources",
 * "file:/tmp/x/resources", a plain path): percent-escapes decoded. Returns 0,
 * or nonzero when the URI is not a local file URI. */
int record_uri_to_path(const char *uri, char *out, size_t outLen);

#endif
