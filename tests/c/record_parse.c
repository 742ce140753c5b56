/* The record reader's numbers (record.c: parse_number, whose fast path parse_decimal reads m 10^e exactly where
 * m <= 2^53 and |e| <= 22) against strtod on the same token, at random tokens of every form a record holds: signs,
 * leading and trailing zeros, 1 to 21 digits with the point anywhere or absent, exponents from -40 to 40 or none,
 * and Python's repr of random doubles of every magnitude. Prints the tokens read, those the fast path read, and
 * those whose value differs from strtod's in any bit (0 expected); tests/test_record_parse.py runs it. White-box:
 * it includes record.c for its static reader. */
#include "record.c"

#include <stdio.h>
#include <stdlib.h>

static unsigned long long state = 88172645463325252ULL;
static unsigned long long next(void) { /* xorshift64 */
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
}

int main(int argc, char **argv) {
    long trials = argc > 1 ? atol(argv[1]) : 2000000;
    long fast = 0, differ = 0;
    char tok[64];
    for (long k = 0; k < trials; k++) {
        int n = 0;
        if (k % 2) { /* a double printed with 1 to 17 significant digits, as Python and C write them */
            union { unsigned long long u; double x; } v;
            do v.u = next(); while (!isfinite(v.x));
            n = snprintf(tok, sizeof(tok), "%.*g", (int)(next() % 17) + 1, v.x);
        } else {
            if (next() % 3 == 0) tok[n++] = next() % 2 ? '-' : '+';
            int digits = (int)(next() % 21) + 1, point = (int)(next() % (digits + 2)) - 1;
            for (int i = 0; i < digits; i++) {
                if (i == point) tok[n++] = '.';
                tok[n++] = (char)('0' + (next() % 4 == 0 ? 0 : next() % 10));
            }
            if (point == digits) tok[n++] = '.';
            if (next() % 2) n += snprintf(tok + n, sizeof(tok) - (size_t)n, "%s%d", next() % 2 ? "e" : "E",
                                          (int)(next() % 81) - 40);
        }
        tok[n] = '\0';
        double a, b;
        if (parse_number(tok, (size_t)n, '.', &a)) continue; /* (e.g. "-.": no number) */
        b = strtod(tok, NULL);
        if (!parse_decimal(tok, (size_t)n, &a)) fast++;
        if (memcmp(&a, &b, sizeof(a)) != 0) {
            if (differ < 5) fprintf(stderr, "%s: %.17g, strtod %.17g\n", tok, a, b);
            differ++;
        }
    }
    printf("%ld %ld %ld\n", trials, fast, differ);
    return 0;
}
