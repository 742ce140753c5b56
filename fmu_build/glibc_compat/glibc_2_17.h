/* Force-included (gcc -include) into every C file of the linux64 binary by
 * fmu_build on x86_64 glibc, so that the binary loads on glibc 2.17 or newer.
 *
 * A shared object records, for each glibc function it calls, the symbol
 * version it was linked against: the newest one in the build machine's
 * glibc. Where glibc has added a newer version of a function, the
 * directives below bind the calls to the oldest version instead, which
 * every x86_64 glibc has (GLIBC_2.2.5 is its first). This is the least
 * intrusive of the sound ways to do it: no old sysroot or build container,
 * and the C sources stay unchanged. On a given glibc, the old versions
 * compute what the new ones do: the libm functions' new versions only
 * dropped a wrapper for SVID error handling (which sets errno, and which
 * glibc 2.27 made plain POSIX), and memcpy's old version is memmove, right
 * for any arguments. (An older glibc brings its own older libm, whose results
 * may differ in the last bit, as for any binary that calls it.)
 * A directive for a function a file does not call adds nothing.
 * stat is different: before 2.33 glibc had no stat to link against, so its
 * calls go to the binary's own function in glibc_2_17.c (a macro renames
 * them, and the declaration in <sys/stat.h> with them, so that the binary
 * defines no function of libc's).
 * tests/test_fmu_binaries.py checks every versioned symbol of the binary.
 *
 * Only directives: including a system header here would fix the feature
 * macros before a source file sets its own (fmi2.c sets _POSIX_C_SOURCE). */
#ifndef ROCKING_GLIBC_2_17_H
#define ROCKING_GLIBC_2_17_H
#if defined(__linux__) && defined(__x86_64__)
__asm__(".symver memcpy,memcpy@GLIBC_2.2.5");
/* libm: new versions in 2.27 (float), 2.29, 2.32 and 2.35, same results */
__asm__(".symver exp,exp@GLIBC_2.2.5");
__asm__(".symver exp2,exp2@GLIBC_2.2.5");
__asm__(".symver log,log@GLIBC_2.2.5");
__asm__(".symver log2,log2@GLIBC_2.2.5");
__asm__(".symver pow,pow@GLIBC_2.2.5");
__asm__(".symver expf,expf@GLIBC_2.2.5");
__asm__(".symver exp2f,exp2f@GLIBC_2.2.5");
__asm__(".symver logf,logf@GLIBC_2.2.5");
__asm__(".symver log2f,log2f@GLIBC_2.2.5");
__asm__(".symver powf,powf@GLIBC_2.2.5");
__asm__(".symver exp10f,exp10f@GLIBC_2.2.5");
__asm__(".symver hypot,hypot@GLIBC_2.2.5");
__asm__(".symver hypotf,hypotf@GLIBC_2.2.5");
#define stat(path, buf) rocking_glibc_2_17_stat(path, buf)
#endif
#endif
