"""The record is whole: the loop writes every column of every row it records, and the rows after a
run's end are NaN.

The record of a job starts uninitialised (``np.empty``: filling ≈ 400 KB with NaN before the loop
writes it again cost ≈ 1 % of a 1 s five-bar run); these tests are what makes that safe.  Independent
path: the record memory is poisoned with a value no law computes before the loop runs, so a column
the loop forgot would still hold it; a diverged run and a record reused by the next run of a batch
show the tail.
"""
import numpy as np
import pytest

from mjbench import kernel
from mjbench import scenario as S
from mjbench.backends.multibody import MultibodyPlant
from mjbench.backends.reduced import ReducedPlant

POISON = 7.25e300  # no recorded quantity of these runs comes near it

#: compositions that cover every column family: two axes; one axis with every drive-train column
#: (sensor, bridge voltage and mean current, the switching amplifier's min/max current, the current
#: loop's reference); the multibody closure column; a plant with columns of its own (the elastic belt's
#: deflection, written by the plant's law)
CASES = {
    "fivebar_reduced": ("fivebar", [], "pid", "reduced"),
    "drivetrain_reduced": ("incerti2012", ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"',
                                           "drive.pwm.v_bus=48", "drive.encoder.lines=2000",
                                           'drive.current_loop.bandwidth="1 kHz"', "drive.i_max=20"], "pid",
                           "reduced"),
    "fourbar_multibody": ("incerti2012", [], "pid", "multibody"),
    "elastic_reduced": ("incerti-belt", [], None, "reduced"),
}


def _plant(scn, mc, backend):
    if backend == "reduced":
        return ReducedPlant(mc, float(scn.simulation.dt))
    return MultibodyPlant(mc, scn.multibody_options())


@pytest.mark.parametrize("mode", ["python", "compiled"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_the_loop_writes_every_column_of_every_row_it_records(case, mode):
    name, sets, ctrl, backend = CASES[case]
    scn = S.load(name, sets)
    mc = S.make_machine(scn, ctrl)
    h = float(scn.simulation.dt)
    nsteps, decim = 400, 10
    plant = _plant(scn, mc, backend)
    plant.start()
    pr = kernel.Program.build(plant, mc, h, kernel.machine_every(mc, h))
    nrec = nsteps // decim + 1
    out = np.full(nrec * len(pr.columns), POISON)
    stats = np.full(nrec * len(pr.stat_columns), POISON)
    st = kernel.Stepper(plant, mc, h, nsteps, decim, mode, pr, out, stats=stats)
    while not st.done:
        st.advance(st.n + 1000)
    assert st.mode == mode and not st.diverged
    assert st.nrows == nrec
    rec = out.reshape(nrec, -1)
    missing = sorted({pr.columns[j] for j in np.nonzero((rec == POISON).any(axis=0))[0]})
    assert not missing, f"{case} ({mode} loop): columns never written: {missing}"
    srec = stats.reshape(nrec, -1)
    missing = sorted({pr.stat_columns[j] for j in np.nonzero((srec == POISON).any(axis=0))[0]})
    assert not missing, f"{case} ({mode} loop): statistics never written: {missing}"


def test_a_diverged_run_leaves_nan_after_its_last_row_also_in_a_reused_record():
    """Runs of a batch consumed one by one share their thread's record: a run that ends early (here a
    runaway current) after a run that filled every row must not show that run's rows."""
    good = S.make_machine(S.load("incerti2012"), "open")
    bad = S.make_machine(S.load("incerti2012", ["drive.v_max=1e9", "modes.open.voltage=1e7"]), "open")
    h = 1e-4
    kept = []

    def consume(i, rec):
        kept.append((rec.nrows[0], rec.data.copy(), rec.stats.copy()))

    rec = kernel.run_many([ReducedPlant(good, h), ReducedPlant(bad, h)], [good, bad], 0.05, 1e-3,
                          threads=1, consume=consume)
    assert rec.diverged.tolist() == [False, True]
    (n0, d0, s0), (n1, d1, s1) = kept
    assert n0 == d0.shape[0] and 0 < n1 < n0
    assert np.all(np.isfinite(d0)) and np.all(np.isfinite(d1[:n1, :10]))
    assert np.all(np.isnan(d1[n1:])) and np.all(np.isnan(s1[n1:]))
    # the same job kept whole: the same rows, NaN after the diverged run's last one
    whole = kernel.run_many([ReducedPlant(good, h), ReducedPlant(bad, h)], [good, bad], 0.05, 1e-3)
    np.testing.assert_array_equal(whole.data[1], d1)
    np.testing.assert_array_equal(whole.data[0], d0)

