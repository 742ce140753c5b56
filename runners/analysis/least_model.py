"""The least model a scene needs (``runners simulate --method auto``) lives in the engine,
runners.engine.least_model, which runners.simulate uses; its names are here too, for code that
reads them from the analysis layer."""

from runners.engine.least_model import (CASES, ROCKING_SLIDING, ROCKING_SLIDING_STACK, SLIDING_MODELS,  # noqa: F401
                                        choose_model, closed_form_summary, combined_block_parameters,
                                        format_closed_form, one_block_parameters, rigid_rocking_parameters,
                                        rocking_sliding_parameters, rocking_sliding_reason, sliding_contact,
                                        sliding_model, stays_locked)
