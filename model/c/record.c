/* Reading record files (format in record.h and docs/records.md). */
#include "record.h"

#include <ctype.h>
#include <errno.h>
#include <locale.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#define MAX_TOKEN 512 /* a number written out longer than this is not a sample */

/* A record line is at most a few numbers: a file larger than this cannot be
 * a record of at most RECORD_MAX_SAMPLES samples with sensible comments. */
#define RECORD_MAX_BYTES (1024.0 * 1024.0 * 1024.0)

/* (uses the current line number, `line`) */
#define FAIL_LINE(...)                                                  \
    do {                                                                \
        int k_ = snprintf(msg, n, "record file '%s', line %d: ", path, line); \
        if (k_ > 0 && (size_t)k_ < n) snprintf(msg + k_, n - (size_t)k_, __VA_ARGS__); \
        goto fail;                                                      \
    } while (0)

#define FAIL_FILE(...)                                                  \
    do {                                                                \
        int k_ = snprintf(msg, n, "record file '%s' ", path);          \
        if (k_ > 0 && (size_t)k_ < n) snprintf(msg + k_, n - (size_t)k_, __VA_ARGS__); \
        goto fail;                                                      \
    } while (0)

void record_free(Record *r, RecordFree release) {
    if (r->t) release(r->t);
    if (r->ah) release(r->ah);
    if (r->av) release(r->av);
    memset(r, 0, sizeof(*r));
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/* The decimal number tok[0..len) ([sign] digits [. digits] [e [sign] digits], '.' the point) exactly, where it
 * is m 10^e with an integer m <= 2^53 and |e| <= 22: then m and 10^e are doubles and one correctly rounded product
 * or quotient is the correctly rounded value (Clinger 1990), strtod's. Returns 0 there; 1 for any other token
 * (strtod reads it). A record's samples, written with up to 17 digits, mostly are such numbers, read about ten
 * times faster than by strtod. */
static int parse_decimal(const char *tok, size_t len, double *value) {
    static const double POW10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                     1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
    size_t i = 0;
    int negative = 0, digits = 0, significant = 0, exp10 = 0;
    unsigned long long m = 0;
    if (i < len && (tok[i] == '+' || tok[i] == '-')) negative = tok[i++] == '-';
    for (int point = 0; i < len; i++) {
        char c = tok[i];
        if (c == '.' && !point) {
            point = 1;
            continue;
        }
        if (c < '0' || c > '9') break;
        digits++;
        if (m || c != '0') significant++;
        if (significant > 19) return 1;
        m = 10 * m + (unsigned long long)(c - '0');
        exp10 -= point;
    }
    if (!digits) return 1;
    if (i < len && (tok[i] == 'e' || tok[i] == 'E')) {
        int sign = 1, e = 0, ed = 0;
        i++;
        if (i < len && (tok[i] == '+' || tok[i] == '-')) sign = tok[i++] == '-' ? -1 : 1;
        for (; i < len && tok[i] >= '0' && tok[i] <= '9'; i++, ed++)
            if (e < 10000) e = 10 * e + (tok[i] - '0');
        if (!ed) return 1;
        exp10 += sign * e;
    }
    if (i != len || m > (1ULL << 53)) return 1;
    double x = (double)m;
    if (m == 0) x = 0.0;
    else if (exp10 >= 0 && exp10 <= 22) x *= POW10[exp10];
    else if (exp10 < 0 && exp10 >= -22) x /= POW10[-exp10];
    else return 1;
    *value = negative ? -x : x;
    return 0;
}

/* Parse the number in tok[0..len) with '.' as the decimal point, whatever the
 * locale (an importer may run with a locale whose decimal point is ','): point is the
 * locale's, which strtod reads. */
static int parse_number(const char *tok, size_t len, char point, double *value) {
    char buf[MAX_TOKEN];
    if (len == 0 || len >= MAX_TOKEN) return 1;
    if (!parse_decimal(tok, len, value)) return 0;
    memcpy(buf, tok, len);
    buf[len] = '\0';
    for (size_t i = 0; i < len; i++) {
        char c = buf[i];
        if (c == ',' && point != ',') return 1;
        if (c == '.' && point != '.') buf[i] = point;
        if (!(isdigit((unsigned char)c) || c == '.' || c == '+' || c == '-' || c == 'e' || c == 'E' ||
              c == 'n' || c == 'N' || c == 'a' || c == 'A' || c == 'i' || c == 'I' || c == 'f' || c == 'F' ||
              c == 't' || c == 'T' || c == 'y' || c == 'Y'))
            return 1;
    }
    char *end = NULL;
    errno = 0;
    *value = strtod(buf, &end);
    if (end != buf + len) return 1;
    return 0;
}

/* Split one line into at most 4 values; returns the count, or -1 (a token
 * that is not a number: its text in bad), -2 (an empty value between
 * separators) or -3 (spaces between some values, commas between others: a
 * decimal comma, most likely). */
static int split_values(const char *p, const char *e, char point, double *vals, char *bad, size_t badLen) {
    int count = 0, spaced = 0, commas = 0;
    while (p < e && is_space(*p)) p++;
    while (p < e) {
        const char *s = p;
        while (p < e && !is_space(*p) && *p != ',' && *p != ';') p++;
        if (p == s) return -2;
        if (count < 4) {
            double v;
            if (parse_number(s, (size_t)(p - s), point, &v)) {
                size_t k = (size_t)(p - s) < badLen - 1 ? (size_t)(p - s) : badLen - 1;
                memcpy(bad, s, k);
                bad[k] = '\0';
                for (size_t i = 0; i < k; i++)
                    if (!isprint((unsigned char)bad[i])) bad[i] = '?';
                return -1;
            }
            vals[count] = v;
        }
        count++;
        while (p < e && is_space(*p)) p++;
        if (p < e && (*p == ',' || *p == ';')) {
            p++;
            commas = 1;
            while (p < e && is_space(*p)) p++;
            if (p == e) return -2;
        } else if (p < e) {
            spaced = 1;
        }
        if (spaced && commas) return -3;
    }
    return count;
}

/* x with the fewest significant digits (15 to 17) that read back as x. */
static const char *shortest(double x, char *buf, size_t n) {
    for (int digits = 15; digits <= 17; digits++) {
        snprintf(buf, n, "%.*g", digits, x);
        if (strtod(buf, NULL) == x) break;
    }
    return buf;
}

/* End of the line that starts at p (its LF, CR or the buffer's end), and where the next starts. */
static const char *line_end(const char *p, const char *end, const char **next) {
    const char *q = p;
    while (q < end && *q != '\n' && *q != '\r') q++;
    *next = q + (q < end && *q == '\r' && q + 1 < end && q[1] == '\n' ? 2 : 1);
    return q;
}

/* First non-blank character of the line [p, e) is a comment mark, or the line is blank. */
static int skip_line(const char *p, const char *e) {
    while (p < e && is_space(*p)) p++;
    return p == e || *p == '#';
}

static unsigned long long fnv1a(unsigned long long h, const void *data, size_t len) {
    const unsigned char *b = (const unsigned char *)data;
    for (size_t i = 0; i < len; i++) {
        h ^= b[i];
        h *= 1099511628211ULL;
    }
    return h;
}

int record_read(const char *path, Record *r, RecordAlloc alloc, RecordFree release, char *msg, size_t n) {
    char *buf = NULL;
    FILE *f = NULL;
    struct stat st;
    memset(r, 0, sizeof(*r));
    if (stat(path, &st) != 0) FAIL_FILE("cannot be opened: %s", strerror(errno));
    if (!S_ISREG(st.st_mode)) FAIL_FILE("is not a regular file");
    if ((double)st.st_size > RECORD_MAX_BYTES)
        FAIL_FILE("is %.3g bytes, larger than any record of at most %d samples", (double)st.st_size,
                  RECORD_MAX_SAMPLES);
    f = fopen(path, "rb");
    if (!f) FAIL_FILE("cannot be opened: %s", strerror(errno));
    size_t size = (size_t)st.st_size;
    buf = (char *)alloc(size + 1, 1);
    if (!buf) FAIL_FILE("is too large to read into memory (%zu bytes)", size);
    size_t got = fread(buf, 1, size, f);
    if (got != size && ferror(f)) FAIL_FILE("could not be read completely: %s", strerror(errno));
    fclose(f);
    f = NULL;
    size = got; /* a file that shrank, or a system file whose size is nominal */
    const char *start = buf, *end = buf + size;
    if (size >= 3 && (unsigned char)buf[0] == 0xEF && (unsigned char)buf[1] == 0xBB &&
        (unsigned char)buf[2] == 0xBF)
        start += 3; /* a UTF-8 byte-order mark */

    /* first pass: count the data lines */
    long long data = 0;
    for (const char *p = start, *next; p < end; p = next) {
        const char *e = line_end(p, end, &next);
        if (!skip_line(p, e)) data++;
        if (data > RECORD_MAX_SAMPLES)
            FAIL_FILE("has more than %d samples (the most a record may have)", RECORD_MAX_SAMPLES);
    }
    if (data == 0) FAIL_FILE("has no samples (expected lines of: time in s, horizontal acceleration in m/s2)");
    r->t = (double *)alloc((size_t)data, sizeof(double));
    r->ah = (double *)alloc((size_t)data, sizeof(double));
    if (!r->t || !r->ah) FAIL_FILE("is too large to hold in memory (%lld samples)", data);

    /* second pass: parse and check */
    int line = 0, columns = 0, firstLine = 0, k = 0;
    const struct lconv *lc = localeconv();
    char point = (lc && lc->decimal_point && lc->decimal_point[0]) ? lc->decimal_point[0] : '.';
    for (const char *p = start, *next; p < end; p = next) {
        const char *e = line_end(p, end, &next);
        line++;
        if (memchr(p, '\0', (size_t)(e - p)))
            FAIL_LINE("contains a NUL byte: this is not a text record file");
        if (skip_line(p, e)) continue;
        double v[4];
        char bad[24];
        int c = split_values(p, e, point, v, bad, sizeof(bad));
        /* Quote nothing of a file that has not shown a sample yet: it may not be a record
         * at all (pointed at /etc/passwd, the log printed its first line). */
        if (c == -1 && k == 0)
            FAIL_LINE("not a record file: its first data line is not two or three numbers (time in s, horizontal "
                      "acceleration in m/s2, optional vertical; a header line must start with '#')");
        if (c == -1) FAIL_LINE("'%s' is not a number", bad);
        if (c == -2) FAIL_LINE("an empty value between separators");
        if (c == -3)
            FAIL_LINE("spaces between some values and commas between others: write decimals with '.' and "
                      "separate the values one way");
        if (c != 2 && c != 3)
            FAIL_LINE("%d values, expected 2 or 3 (time in s, horizontal acceleration in m/s2, "
                      "optional vertical acceleration in m/s2)", c);
        if (columns == 0) {
            columns = c;
            firstLine = line;
            if (c == 3) {
                r->vertical = 1;
                r->av = (double *)alloc((size_t)data, sizeof(double));
                if (!r->av) FAIL_FILE("is too large to hold in memory (%lld samples)", data);
            }
        } else if (c != columns) {
            FAIL_LINE("%d values, but line %d has %d (every line needs the same columns)", c, firstLine,
                      columns);
        }
        for (int j = 0; j < c; j++)
            if (!isfinite(v[j])) FAIL_LINE("%s is not a finite number", j == 0 ? "the time" : "an acceleration");
        if (fabs(v[0]) > RECORD_MAX_TIME) {
            char tv[32];
            FAIL_LINE("|time| = %s s is beyond a million seconds: is the first column the time in seconds?",
                      shortest(fabs(v[0]), tv, sizeof(tv)));
        }
        for (int j = 1; j < c; j++)
            if (fabs(v[j]) > RECORD_MAX_ACCELERATION)
                FAIL_LINE("|%s acceleration| = %g m/s2 exceeds 10 g: are the values in m/s2?",
                          j == 1 ? "horizontal" : "vertical", fabs(v[j]));
        if (k > 0) {
            double dt = v[0] - r->t[k - 1];
            char now[32], before[32];
            if (!(dt > 0))
                FAIL_LINE("time %s s does not increase (previous sample %s s)", shortest(v[0], now, sizeof(now)),
                          shortest(r->t[k - 1], before, sizeof(before)));
            if (dt < RECORD_MIN_INTERVAL)
                FAIL_LINE("sample interval %g s is below %g s: absurd sampling (is time in seconds?)", dt,
                          RECORD_MIN_INTERVAL);
            if (dt > RECORD_MAX_INTERVAL)
                FAIL_LINE("sample interval %g s is above %g s: absurd sampling (is time in seconds?)", dt,
                          RECORD_MAX_INTERVAL);
        }
        r->t[k] = v[0];
        r->ah[k] = v[1];
        r->peak = fmax(r->peak, fabs(v[1]));
        if (r->vertical) {
            r->av[k] = v[2];
            r->peak = fmax(r->peak, fabs(v[2]));
        }
        k++;
    }
    if (k < 2) FAIL_FILE("has only one sample: a record needs at least two");
    r->n = k;
    release(buf);
    buf = NULL;
    unsigned long long h = 1469598103934665603ULL;
    h = fnv1a(h, &r->n, sizeof(r->n));
    h = fnv1a(h, r->t, (size_t)k * sizeof(double));
    h = fnv1a(h, r->ah, (size_t)k * sizeof(double));
    if (r->vertical) h = fnv1a(h, r->av, (size_t)k * sizeof(double));
    r->hash = h;
    return 0;
fail:
    if (f) fclose(f);
    if (buf) release(buf);
    record_free(r, release);
    return 1;
}

int record_is_absolute(const char *p) {
    if (p[0] == '/' || p[0] == '\\') return 1;
    return isalpha((unsigned char)p[0]) && p[1] == ':' && (p[2] == '/' || p[2] == '\\');
}

int record_path(const char *file, const char *resourceDir, char *out, size_t outLen, char *msg, size_t n) {
    if (!file || !file[0]) {
        snprintf(msg, n, "no file given: name the record file of excitation.kind = 4 (record)");
        return 1;
    }
    int k;
    if (record_is_absolute(file)) {
        k = snprintf(out, outLen, "%s", file);
    } else {
        if (!resourceDir || !resourceDir[0]) {
            snprintf(msg, n, "'%s' is a relative path, but the importer gave no resources folder to "
                     "resolve it against: give an absolute path", file);
            return 1;
        }
        k = snprintf(out, outLen, "%s/%s", resourceDir, file);
    }
    if (k < 0 || (size_t)k >= outLen) {
        snprintf(msg, n, "the path is longer than %zu bytes", outLen - 1);
        return 1;
    }
    return 0;
}

static int hex(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

int record_uri_to_path(const char *uri, char *out, size_t outLen) {
    const char *p = uri;
    char prefix[3] = "";
    if (!uri || outLen < 2) return 1;
    if (strncmp(p, "file://", 7) == 0) {
        p += 7;
        if (strncmp(p, "localhost/", 10) == 0) p += 9;
        else if (*p != '/') strcpy(prefix, "//"); /* file://host/share: a UNC path */
    } else if (strncmp(p, "file:/", 6) == 0) {
        p += 5;
    } else if (strncmp(p, "file:", 5) == 0 || strstr(p, "://")) {
        return 1; /* not a local file URI */
    }
    size_t k = 0;
    for (const char *q = prefix; *q; q++) out[k++] = *q;
    for (; *p; p++) {
        char c = *p;
        if (c == '%' && hex(p[1]) >= 0 && hex(p[2]) >= 0) {
            c = (char)(hex(p[1]) * 16 + hex(p[2]));
            p += 2;
        }
        if (k + 1 >= outLen) return 1;
        out[k++] = c;
    }
    out[k] = '\0';
    /* "/C:/x" is the URI form of the Windows path "C:/x" */
    if (out[0] == '/' && isalpha((unsigned char)out[1]) && out[2] == ':') memmove(out, out + 1, k);
    k = strlen(out);
    while (k > 1 && (out[k - 1] == '/' || out[k - 1] == '\\')) out[--k] = '\0';
    return 0;
}
