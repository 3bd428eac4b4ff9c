"""scripts/_residual_data.py: the recorded-data split of scripts/train_residual.py.

Recorded data is stood in for by synthetic handshakes written as ``npz:`` folders (the loaders of the
shared recordings are tested elsewhere; the split only sees instances, labels, actors and sources):
one folder whose instances recur in actor pairs, labelled ``shaking_hands``, one labelled
``handshake``. Checked: the held-out fold and the training folds partition each class, no held-out
pair is trained on under the pair split, the block split holds out a contiguous block, the seed and
the fold choose the split, and bad flags fail with the flag's name.
"""

from __future__ import annotations

import pytest
from conftest import load_script

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.data.npz_format import save_dataset
from socialaff_sim.data.synthetic import generate_dataset
from socialaff_sim.data.synthetic.config import SyntheticConfig
from socialaff_sim.errors import ConfigError


@pytest.fixture(scope="module")
def rd():  # noqa: ANN201
    return load_script("_residual_data")


PAIRS = [("p1", "q1"), ("p2", "q2"), ("p3", "q3"), ("q1", "p1"), ("p2", "q2"), ("p4", "q4")]


@pytest.fixture(scope="module")
def specs(tmp_path_factory):  # noqa: ANN201
    """Two ``npz:`` datasets, each cut from one recording: 6 ``shaking_hands`` instances in 4 unordered
    actor pairs, 5 ``handshake``."""
    insts = list(generate_dataset(5, SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=11)))
    root = tmp_path_factory.mktemp("recorded")
    a = [inst.replace(label="shaking_hands", actors=PAIRS[k], instance_id=f"a_{k}", source=f"rec_a @ {k}.0-{k + 1}.0 s")
         for k, inst in enumerate(insts[:6])]
    b = [inst.replace(label="handshake", actors=("u", "v"), instance_id=f"b_{k}", source=f"rec_b @ {k}.0-{k + 1}.0 s")
         for k, inst in enumerate(insts[6:])]  # one continuous recording cut into instances, as NuiSI is
    save_dataset(Dataset("a", a), root / "a")
    save_dataset(Dataset("b", b), root / "b")
    return f"npz:{root / 'a'}", f"npz:{root / 'b'}"


def test_parse_splits(rd) -> None:  # noqa: ANN001
    assert rd.parse_splits(["pair", "nuisi=block"]) == {"": "pair", "nuisi": "block"}
    splits = rd.parse_splits(["recording", "npz=block"])
    assert rd.split_for("npz:/x", splits) == "block" and rd.split_for("sbu:/x", splits) == "recording"
    for bad in (["pairs"], ["=pair"], ["nuisi=blocks"]):
        with pytest.raises(ConfigError, match="--split"):
            rd.parse_splits(bad)
    with pytest.raises(ConfigError, match="no split given for dataset kind 'sbu'"):
        rd.split_for("sbu:/x", rd.parse_splits(["nuisi=block"]))


def test_pair_split_partitions_each_class_and_holds_pairs_apart(rd, specs) -> None:  # noqa: ANN001
    labels = ["shaking_hands", "handshake"]
    splits = rd.parse_splits(["pair", "npz=pair"])
    train, held, table = rd.real_split([specs[0]], labels[:1], splits, 2, 0, 0)
    (row,) = table
    assert row.label == "shaking_hands" and row.split == "pair"
    assert sorted(row.train_ids + row.held_out_ids) == [f"a_{k}" for k in range(6)]
    assert [i.instance_id for i in train] == list(row.train_ids) and [i.instance_id for i in held] == list(row.held_out_ids)
    pair = {f"a_{k}": frozenset(p) for k, p in enumerate(PAIRS)}
    assert not {pair[i] for i in row.train_ids} & {pair[i] for i in row.held_out_ids}
    # the other fold holds out exactly the training instances of this one
    _, _, (other,) = rd.real_split([specs[0]], labels[:1], splits, 2, 1, 0)
    assert set(other.held_out_ids) == set(row.train_ids) and set(other.train_ids) == set(row.held_out_ids)
    # the same seed gives the same split; over a few seeds the dealing changes it
    assert rd.real_split([specs[0]], labels[:1], splits, 2, 0, 0)[2] == table
    assert len({rd.real_split([specs[0]], labels[:1], splits, 2, 0, s)[2][0].held_out_ids for s in range(6)}) > 1


def test_block_split_and_several_datasets(rd, specs) -> None:  # noqa: ANN001
    splits = rd.parse_splits(["pair", "npz=block"])
    train, held, table = rd.real_split(list(specs), ["shaking_hands", "handshake"], splits, 2, 0, 3)
    by_label = {t.label: t for t in table}
    assert set(by_label) == {"shaking_hands", "handshake"} and all(t.split == "block" for t in table)
    # block: the first contiguous block of each one recording (np.array_split of 5 into 2: 3 then 2)
    assert by_label["shaking_hands"].held_out_ids == ("a_0", "a_1", "a_2")
    assert by_label["handshake"].held_out_ids == ("b_0", "b_1", "b_2")
    assert by_label["handshake"].train_ids == ("b_3", "b_4")
    assert len(train) + len(held) == 11 and not {i.instance_id for i in train} & {i.instance_id for i in held}


def test_bad_arguments_name_the_flag(rd, specs) -> None:  # noqa: ANN001
    splits = rd.parse_splits(["pair"])
    with pytest.raises(ConfigError, match="--held-out-fold"):
        rd.real_split([specs[0]], ["shaking_hands"], splits, 2, 2, 0)
    with pytest.raises(ConfigError, match="--interactions: no instance of 'hand_over'"):
        rd.real_split([specs[0]], ["shaking_hands", "hand_over"], splits, 2, 0, 0)
    with pytest.raises(ConfigError, match="share an id"):
        rd.real_split([specs[0], specs[0]], ["shaking_hands"], splits, 2, 0, 0)
