"""The six experiments of the paper's Section IV: the registry (EXPERIMENTS, TRIAL_SETS) and
every experiment's names, re-exported from their modules (one module per experiment):

  paper               the paper's reference numbers (Tables I and II, new circumstances, Fig. 4)
  context             settings (defaults, --quick), Context, the policies' certification report
  exp1_navigation     exp1: navigation transfer
  exp2_delivery       exp2: Table I (delivery trials) and the serve-reward ablation
  exp3_qa_cdf         exp3: CDFs of the QA cost
  exp4_entropy        exp4: Table II (entropy at the serve)
  exp5_circumstances  exp5: new circumstances
  exp6_dialog_script  exp6: the Figure 4 dialog

Each experiment builds TrialSpecs for the core CLIs, runs them through the context's Runner
(or replays recorded trials), computes its tables with krr_eval.stats, draws its figures,
and states the paper's claims with our evidence and a verdict. Columns are read from the CSV
headers by name (see the *_COLUMNS notes in each module for what each CLI must provide).

Trial counts default to the paper's (1000 per point for navigation, 10,000 per blocking rate
for Table I); where the paper gives none we say what we use.
"""
import collections
import math

from . import stats  # noqa: F401  (experiments.stats)
from .paper import (  # noqa: F401
    PAPER_TABLE1, PAPER_TABLE1_P, PAPER_TABLE2, PAPER_NEW_CIRCUMSTANCES, PAPER_QUESTIONS,
    PAPER_GOAL,
)
from .context import (  # noqa: F401
    CONDITIONS, CONDITION_LABEL, DEFAULTS, QUICK, TITLES, Context, norm_room, _sub,
    UnconvergedPolicy, solver_precision, question_cost, FORCED_LIMIT, policy_report, solver_args,
)
from .exp1_navigation import (  # noqa: F401
    NAV_COLUMNS, NAV_TRIAL_COST, nav_spec, exp1_specs, exp1_nav_transfer,
)
from .exp2_delivery import (  # noqa: F401
    CHEAP_TRIALS_CHUNK, DELIVERY_COLUMNS, delivery_specs, _subsample, OUTDATED_BR, PILOT,
    BUDGET_CPU_S, TARGET_HALF, _paired_index, delivery_data, _mean, _rate, _nav_by_room,
    _pair_stats, _cmp, _certainty_clause, _gap_clause, _diff_text, _reward_reason,
    _realised_reason, _identified_reason, _qa_reason, exp2_fulfilment_note,
    exp2_trial_count_note, exp2_table1, ablation_specs, serve_reward_ablation,
)
from .exp3_qa_cdf import (  # noqa: F401
    paper_cdf_br, _room_clause, _lower_qa_claim, exp3_cdf,
)
from .exp4_entropy import (  # noqa: F401
    ENTROPY_COLUMNS, ENTROPY_UNIT, deliveries_only, _exp2_nav, _nav_flat, entropy_specs,
    exp4_table2,
)
from .exp5_circumstances import (  # noqa: F401
    MERGED_COLUMNS, EXP5_MIN_CHUNK, EXP5_LABELS, _exp5_pct, _exp5_key_label, _exp5_short,
    exp5_evidence, _exp5_groups, _exp5_rate, _exp5_pick_expectation, _exp5_other_rate,
    _exp5_by_run, exp5_tables, _exp5_discordant, _exp5_extremes, _exp5_group_text, exp5_claims,
    exp5_magnitude_reason, exp5_notes, exp5_analysis, exp5_spec, exp5_new_circumstances,
)
from .exp6_dialog_script import (  # noqa: F401
    SCRIPT_COLUMNS, DIMS, read_turns, _asks_person, _belief_text, _questions, _script_args,
    exp6_dialog, _turn_caption, _wrap,
)


EXPERIMENTS = collections.OrderedDict([
    ("exp1", exp1_nav_transfer), ("exp2", exp2_table1), ("exp3", exp3_cdf),
    ("exp4", exp4_table2), ("exp5", exp5_new_circumstances), ("exp6", exp6_dialog)])
# The trial sets of each experiment, for Runner.prefetch (the experiments ask for the same).
TRIAL_SETS = {
    "exp1": lambda ctx: list(exp1_specs(ctx).values()),
    "exp2": lambda ctx: list(delivery_specs(ctx).values()) + list(ablation_specs(ctx).values()),
    "exp4": lambda ctx: list(entropy_specs(ctx).values()),
    "exp5": lambda ctx: [exp5_spec(ctx)],
}


def trial_sets(ctx, keys):
    """Every trial set the experiments `keys` will run, in their order."""
    return [s for k in keys if k in TRIAL_SETS for s in TRIAL_SETS[k](ctx)]


COLUMNS = {"nav_transfer (--trials-out)": NAV_COLUMNS, "delivery_trials": DELIVERY_COLUMNS,
           "dialog_entropy": ENTROPY_COLUMNS, "new_circumstances": MERGED_COLUMNS,
           "dialog_script": SCRIPT_COLUMNS}


def is_nan(x):
    return isinstance(x, float) and math.isnan(x)
