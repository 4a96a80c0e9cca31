"""Issue 27's acceptance script, unmodified: load the Incerti 2012 scenario with one value changed
(units allowed), simulate 0.5 s of the K_p·t PID on both backends, read the record as a
DataFrame, print the mean crank speed, and write the folder `mjbench run` writes (./out_api).

    python scripts/examples/acceptance.py        # ~3 s; tests/test_examples.py runs it
"""
import mjbench as mjb
scn = mjb.load("incerti2012", **{"drive.R": "2.2 ohm"})
res = scn.simulate(mode="pid", backend="both", t_end=0.5)
df = res.to_pandas()                       # one row per recorded sample, SI column names
print(res.metrics["backends"]["multibody"]["mean_crank_speed_rad_s"])
res.save("out_api")                        # the files `mjbench run` writes
