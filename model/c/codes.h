/* The Integer codes of the Enumeration parameters (excitation.kindCode, ...), for
 * importers that cannot set an Enumeration variable (libcosim and Ecos list none of
 * an FMI 2.0 FMU's). A code other than -1 (its start value) replaces its Enumeration
 * when the instance enters and when it leaves initialisation mode (a code set in
 * initialisation mode counts too); -1 leaves the Enumeration as set.
 * The CODE lines of variables.def pair them; the Enumeration's ITEM lines give the
 * values a code may take. Included by the FMI layers (fmi2.c, fmi3.c). */
#ifndef ROCKING_CODES_H
#define ROCKING_CODES_H

#include <string.h>

#include "instance.h"

/* The largest item value of the Enumeration variable called name (-1 if none). */
static int codes_largest_item(const char *name) {
    int largest = -1;
#define VAR(T, ref, field, name_, caus, var, start, unit, desc)
#define RANGE(...)
#define CODE(code, field, codeName, enumName)
#define ITEM(var, type, value, item, desc) \
    if (strcmp(var, name) == 0 && (value) > largest) largest = (value);
#include "variables.def"
#undef ITEM
#undef CODE
#undef RANGE
#undef VAR
    return largest;
}

/* Replace every Enumeration whose code is set; nonzero (after logging why) for a code
 * that is neither -1 nor one of its Enumeration's values. */
static int codes_apply(Instance *I, const char *fn) {
    Variables *v = &I->s.model.v;
#define VAR(T, ref, field, name_, caus, var, start, unit, desc)
#define RANGE(...)
#define ITEM(var, type, value, item, desc)
#define CODE(code, field, codeName, enumName)                                                           \
    if (v->code != -1) {                                                                                \
        int largest_ = codes_largest_item(enumName);                                                    \
        if (v->code < 0 || v->code > largest_) {                                                        \
            INSTANCE_ERROR(I, "%s: invalid parameter: %s = %d must be -1 (keep %s) or a value of %s, 0 to %d", \
                           fn, codeName, v->code, enumName, enumName, largest_);                        \
            return 1;                                                                                   \
        }                                                                                               \
        if (v->field != v->code) I->s.dirty = 1; /* initialise again, with the code's choice */         \
        v->field = v->code;                                                                             \
    }
#include "variables.def"
#undef CODE
#undef ITEM
#undef RANGE
#undef VAR
    return 0;
}

#endif
