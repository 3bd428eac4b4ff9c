"""How many causal evaluation frames lie beyond the interaction primitive's longest training duration T_max.

Within T_max the stream (:class:`~socialaff_sim.inference.primitive_stream.PrimitiveStream`) equals the batch causal
prediction of commit 7f68f7b; beyond it the stream's bounded rule (T̂ = T_max, phase 1) differs from the batch's
(T̂ = the frames seen). For each dataset spec and split, the evaluation's folds (``make_tasks``: per class, the
fold's training instances; the test instances' causal frames t ≥ T0) are rebuilt and counted: frame t is beyond
when t + 1 > T_max of the fold's training set (the primitive's durations are quantiles 0…1 of its durations). On the instances with such
frames, the primitive's key-joint error there (mean over the key joints of the distance to agent 1's, metres) under
both rules: the primitive fitted on the fold's training instances with the default :class:`ProMPConfig`.

    python scripts/primitive_beyond_tmax.py synthetic:pair sbu:PATH:pair handover:PATH:pair nuisi:PATH:block
"""

from __future__ import annotations

import sys

import numpy as np

from socialaff_sim.data.specs import load_dataset
from socialaff_sim.evaluation.crossval import EvaluationConfig, make_tasks
from socialaff_sim.inference.interaction_primitive import InteractionPrimitive
from socialaff_sim.inference.primitive_stream import PrimitiveStream
from socialaff_sim.inference.protocol import observed_part


def main() -> None:
    for arg in sys.argv[1:]:
        spec, split = arg.rsplit(":", 1)
        data = load_dataset(spec)
        config = EvaluationConfig(split=split, executor="serial")
        tasks, _, _ = make_tasks(data, [("full", lambda **_: None)], list(data.labels), config)
        total = beyond = 0
        worst = 0
        err_batch: list[float] = []
        err_stream: list[float] = []
        for task in tasks:
            t_max = max(i.n_frames for i in task.train)
            prim = None
            for inst in task.test:
                frames = inst.n_frames - task.n_observed
                over = max(0, inst.n_frames - t_max)
                total += frames
                beyond += over
                worst = max(worst, over)
                if over == 0:
                    continue
                prim = prim or InteractionPrimitive().fit(task.train)
                hidden, stream, truth = observed_part(inst, task.n_observed), PrimitiveStream(prim, task.n_observed), inst.key_joints()[:, 1]
                for t in range(task.n_observed, inst.n_frames):
                    view = hidden.slice(0, t + 1)
                    got = stream.react_keys(view, t, t + 1)[0]
                    if t + 1 > t_max:
                        ref = prim.react_keys(view, t, t + 1, n_observed=task.n_observed)[0]
                        err_stream.append(float(np.nanmean(np.linalg.norm(got - truth[t], axis=-1))))
                        err_batch.append(float(np.nanmean(np.linalg.norm(ref - truth[t], axis=-1))))
        print(f"{arg}: {total} causal test frames, {beyond} beyond T_max ({100 * beyond / max(total, 1):.2f} %), "
              f"at most {worst} in one instance; the primitive's key-joint error there: batch rule (T̂ = frames seen) "
              f"{np.mean(err_batch) if err_batch else float('nan'):.4f} m, bounded rule (T̂ = T_max) "
              f"{np.mean(err_stream) if err_stream else float('nan'):.4f} m", flush=True)


if __name__ == "__main__":
    main()
