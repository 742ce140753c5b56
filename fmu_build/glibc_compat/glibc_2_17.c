/* stat for the linux64 binary, compiled in by fmu_build on x86_64 glibc
 * (see glibc_2_17.h, which renames the calls of stat to this function):
 * glibc 2.33 made stat a function of libc.so (GLIBC_2.33); before, every
 * call of stat became one of __xstat, which every x86_64 glibc exports, and
 * this does what glibc's own stat did then. Its first argument, 1, is
 * _STAT_VER_LINUX: the x86_64 kernel's struct stat, the one <sys/stat.h>
 * describes. No system header: only pointers pass. */
#if defined(__linux__) && defined(__x86_64__)
struct stat;
extern int __xstat(int ver, const char *path, struct stat *buf);
__asm__(".symver __xstat,__xstat@GLIBC_2.2.5");

__attribute__((visibility("hidden"))) int rocking_glibc_2_17_stat(const char *path, struct stat *buf);
int rocking_glibc_2_17_stat(const char *path, struct stat *buf) { return __xstat(1, path, buf); }
#else
typedef int rocking_glibc_2_17_unused; /* ISO C wants a declaration in every file */
#endif
