"""The held-out engine (issue 45): folds of whole units, the guard, scores per fold, and the
weighted least squares of every fold at once."""

from __future__ import annotations

import numpy as np
import pytest

from limbstiff import heldout


def test_units_dealt_in_turn_or_in_contiguous_blocks():
    unit = np.array([-1, -1, 0, 0, 1, 1, 2, 3, 4, 5, 6])
    assert list(heldout.interleaved(unit, 3)) == [-1, -1, 0, 0, 1, 1, 2, 0, 1, 2, 0]
    # 7 units in 3 blocks: 3, 2, 2 (the first one longer), whole units only
    assert list(heldout.contiguous(unit, 3)) == [-1, -1, 0, 0, 0, 0, 0, 1, 1, 2, 2]
    assert list(heldout.contiguous(np.array([0, 1]), 5)) == [0, 1]          # fewer units than folds


def test_the_guard_keeps_training_away_from_what_a_fold_leaves_out():
    unit = np.repeat(np.arange(6), 10)
    folds = heldout.folds_of(unit, heldout.interleaved(unit, 3), guard=2)
    assert folds.n_folds == 3 and folds.n_units == 6
    for k in range(3):
        held, train = folds.held(k), folds.training[k]
        assert not (held & train).any()
        # a step trains unless it is left out or within two steps of a left-out one
        distance = np.array([np.min(np.abs(i - np.flatnonzero(held))) for i in range(len(unit))])
        assert list(train) == list(distance > 2)
    # no guard: everything but the fold's own steps
    bare = heldout.folds_of(unit, heldout.interleaved(unit, 3), guard=0)
    assert list(bare.training[0]) == list(~bare.held(0))


def test_steps_not_scored_are_neither_left_out_nor_trained_on():
    unit = np.array([-1, -1, 0, 0, 1, 1, 2, 2])
    folds = heldout.folds_of(unit, heldout.interleaved(unit, 3), guard=0, n_folds=4)
    assert not folds.training[:, :2].any() and not any(folds.held(k)[:2].any() for k in range(4))
    assert list(folds.training[3]) == list(unit >= 0)           # a fold that leaves nothing out


def test_joined_records_keep_their_guards_apart():
    a = heldout.folds_of(np.repeat(np.arange(3), 4), heldout.contiguous(np.repeat(np.arange(3), 4), 3), guard=3)
    b = heldout.folds_of(np.repeat(np.arange(3), 4), heldout.contiguous(np.repeat(np.arange(3), 4), 3), guard=0)
    both = heldout.joined([a, b])
    assert both.n_units == 6 and list(both.unit[12:16]) == [3, 3, 3, 3]
    # a's last block (fold 2) guards a's own steps 5-7, not b's first steps
    assert list(both.training[2]) == [True] * 5 + [False] * 7 + [True] * 8 + [False] * 4
    assert list(both.unit_sum(np.ones(24))) == [4.0] * 6


def test_regression_predicts_left_out_folds_from_the_training_ones():
    rng = np.random.default_rng(1)
    m = 3000
    x = rng.standard_normal((m, 2))
    noise = 0.1 * rng.standard_normal(m)
    y = x @ np.array([2.0, -1.0]) + noise
    unit = np.repeat(np.arange(30), 100)
    folds = heldout.folds_of(unit, heldout.interleaved(unit, 5), guard=5)
    scores = heldout.regression(folds, y, x, np.ones(m))
    assert scores.rss.shape == (5,) and np.all(scores.rss > 0)
    assert np.sum(scores.error ** 2) == pytest.approx(np.sum(scores.rss))
    assert np.mean(scores.error ** 2) == pytest.approx(0.01, rel=0.1)      # the noise: nothing is learnt held out
    assert scores.explained == pytest.approx(1 - 0.01 / 5.0, abs=1e-3)
    # a fold scored alone is the same fold scored with the others
    one = heldout.regression(folds, y, x, np.ones(m), which=[2])
    np.testing.assert_allclose(one.error[folds.held(2)], scores.error[folds.held(2)], rtol=1e-9)
    assert not one.error[~folds.held(2)].any()


def test_score_calls_each_fold_with_its_own_steps():
    unit = np.repeat(np.arange(4), 3)
    folds = heldout.folds_of(unit, heldout.interleaved(unit, 2), guard=0)
    target = np.arange(12.0)
    seen = []

    def predict(k):
        seen.append(k)
        return np.full(int(folds.held(k).sum()), float(k))
    scores = heldout.score(folds, target, predict)
    assert seen == [0, 1]
    assert list(scores.error) == list(target - np.repeat([0.0, 1.0, 0.0, 1.0], 3))


def test_normal_equations_block_by_block_equal_the_dense_ones():
    # several trials: each trial's nuisance columns are zero on the others' steps, and summing the
    # normal equations block by block must give exactly the dense product (to rounding)
    rng = np.random.default_rng(0)
    sizes, own, shared = (100, 120, 90), 4, 2
    X = np.zeros((sum(sizes), own * len(sizes) + shared))
    blocks, r0 = [], 0
    for i, n in enumerate(sizes):
        cols = np.r_[own * i:own * (i + 1), own * len(sizes):X.shape[1]]
        X[r0:r0 + n, cols] = rng.normal(size=(n, len(cols)))
        blocks.append((slice(r0, r0 + n), cols))
        r0 += n
    w = (rng.random((4, len(X))) > 0.3).astype(float)
    np.testing.assert_allclose(heldout._gram(X, w, blocks), np.stack([X.T @ (wk[:, None] * X) for wk in w]),
                               atol=1e-10)
