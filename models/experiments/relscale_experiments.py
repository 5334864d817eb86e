"""Relative-scale experiments of models/MODEL_CARD.md ("Relative scale"): the VO's relative scale
r_k = |t_k| / |t_(k-1)| (vo.h, tvo_vo_result.rel_scale) per sequence, scale propagation, and the
complementary filter  log s_k = (1-a)(log s_(k-1) + log r_k) + a log n_k  with a constant-step prior or
the shipped networks' |t| as n_k, its weight a chosen on the TRAINING sequences only.

    cd tools && ../.venv/bin/python ../models/experiments/relscale_experiments.py \
        --features ../out/model/scale/features --seq-root ../out/model/seq --out ../out/model/scale/exp \
        --model ../models/tinyvo_synth_euroc_t_sigmoid.tvonn

--features: tvo_replay --features csv files <NAME>.features.csv (with the rel_scale column) of all eight
sequences. The filter here is the same recursion as tvo_scale_filter_update (vo.h) and the integration that
of tvo_replay (tables.integrate); `tvo_replay --scale model --scale-alpha A` gives the same trajectories
(the card lists both). Writes OUT/results.json and prints the tables.
"""
import argparse
import json
import os

import numpy as np

from tinyvo_tools import dataset as dsmod, nnfmt, tables, trajio

TRAIN = ["MH_01", "MH_02", "MH_03", "V1_01", "V2_01"]
VAL = ["MH_04", "V1_02", "V2_03"]
ALPHAS = [0.0, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]


def seq_data(features_dir, seq_root, name):
    sd = os.path.join(seq_root, name)
    fr = dsmod.read_features_csv(os.path.join(features_dir, f"{name}.features.csv"))
    gt_path, yml = dsmod.sequence_paths(sd)
    g = trajio.read_euroc_groundtruth(gt_path)
    T_wc = trajio.interpolate_poses(g.t_ns, g.poses, fr["t_ns"]) @ trajio.read_sensor_yaml(yml).T_BS
    gs = np.zeros(len(fr["t_ns"]))
    gs[1:] = np.linalg.norm((trajio.inv_pose(T_wc[:-1]) @ T_wc[1:])[:, :3, 3], axis=1)
    return sd, fr, T_wc, gs


def filter_steps(state, r, prior, alpha, seed=None):
    """tvo_replay's step lengths: OK frames run the filter (seed: the first OK frame takes seed[k] and the
    recursion starts there, as --scale propagate); other frames 0 (rotation-only: t = 0 anyway)."""
    s = np.zeros(len(state))
    log_s = None
    for k in range(1, len(state)):
        if state[k] != dsmod.STATE_OK:
            continue
        if log_s is None:
            if seed is not None:
                if seed[k] > 0:
                    log_s = np.log(seed[k])
                    s[k] = seed[k]
                continue
            if not prior[k] > 0:
                continue
            log_s = np.log(prior[k])
        else:
            pred = log_s + (np.log(r[k]) if r[k] > 0 else 0.0)
            log_s = (1 - alpha) * pred + alpha * np.log(prior[k]) if prior is not None and prior[k] > 0 else pred
        log_s = float(np.clip(log_s, np.log(1e-9), np.log(1e3)))
        s[k] = np.exp(log_s)
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    for k in ("features", "seq-root", "out", "model"):
        ap.add_argument(f"--{k}", required=True)
    a = ap.parse_args()
    os.makedirs(os.path.join(a.out, "traj"), exist_ok=True)
    with open(a.model, "rb") as fh:
        model = nnfmt.read(fh.read())
    data = {n: seq_data(a.features, a.seq_root, n) for n in TRAIN + VAL}
    # constant step: the training sequences' mean ground-truth step over the frames the VO integrates
    const = float(np.mean(np.concatenate([data[n][3][1:][np.isin(data[n][1]["state"][1:], (0, 2))]
                                          for n in TRAIN])))
    res = {"const_step_m": const, "relscale": {}, "ate": {}, "paper": {}}
    print(f"constant step (training mean): {const:.4f} m")
    for n, (sd, fr, T_wc, gs) in data.items():
        st, r = fr["state"], fr["rel_scale"]
        ok = np.zeros(len(st), bool)
        ok[2:] = (st[2:] == 0) & (st[1:-1] == 0) & (gs[1:-1] > 0)
        have = ok & (r > 0)
        truth = np.where(ok, gs / np.maximum(np.roll(gs, 1), 1e-12), 0)
        e = np.log(r[have] / truth[have])
        res["relscale"][n] = {"frames_ok_after_ok": int(ok.sum()), "available": int(have.sum()),
                              "median_abs_log_err": float(np.median(np.abs(e))),
                              "rms_log_err": float(np.sqrt(np.mean(e ** 2))), "mean_log_err": float(np.mean(e)),
                              "sum_log_err": float(np.sum(e))}
    print("| sequence | frames OK after OK | r available | median abs error | RMS log error | mean log error |")
    print("|---|---|---|---|---|---|")
    for n, v in res["relscale"].items():
        print(f"| {n} | {v['frames_ok_after_ok']} | {v['available']} | {100 * v['median_abs_log_err']:.2f} % | "
              f"{v['rms_log_err']:.4f} | {v['mean_log_err']:+.4f} |")

    def run(label, name, scale):
        sd, fr, T_wc, gs = data[name]
        raw = np.hstack([fr["features"][:, 3:6], fr["features"][:, 0:3]])
        tp = os.path.join(a.out, "traj", f"{name}.{label}.txt")
        tables.integrate(fr["t_ns"], fr["state"], raw, scale, T_wc[0], tp)
        ev = tables.evaluate(tp, sd)
        res["ate"].setdefault(label, {})[name] = ev["ate_se3_m"]
        res["paper"].setdefault(label, {})[name] = ev["paper_mean_err_m"]
        return ev["ate_se3_m"]

    for name in TRAIN + VAL:
        sd, fr, T_wc, gs = data[name]
        st, r = fr["state"], fr["rel_scale"]
        net = np.linalg.norm(nnfmt.reference_run(model, fr["features"].astype(np.float32))[:, :3].astype(np.float64),
                             axis=1)
        cst = np.full(len(st), const)
        run("gt", name, gs)
        run("const", name, cst)
        run("propagate", name, filter_steps(st, r, None, 0.0, seed=gs))
        run("net_norm", name, net)  # |t| of the shipped nets along the raw direction (alpha = 1)
        for al in ALPHAS:
            run(f"filter_const_a{al:g}", name, filter_steps(st, r, cst, al))
            run(f"filter_net_a{al:g}", name, filter_steps(st, r, net, al))
        print(f"{name}: done", flush=True)

    def mean(label, names):
        return float(np.mean([res["ate"][label][n] for n in names]))
    best = {}
    for prior in ("const", "net"):
        labs = [f"filter_{prior}_a{al:g}" for al in ALPHAS]
        best[prior] = min(labs, key=lambda lab: mean(lab, TRAIN))
    res["chosen_on_training"] = best
    print("\n| method | " + " | ".join(TRAIN) + " | train mean | " + " | ".join(VAL) + " | val mean | val paper mean |")
    print("|---" * (len(TRAIN) + len(VAL) + 4) + "|")
    for lab in res["ate"]:
        row = [res["ate"][lab][n] for n in TRAIN]
        vrow = [res["ate"][lab][n] for n in VAL]
        mark = " (chosen on training)" if lab in best.values() else ""
        print(f"| {lab}{mark} | " + " | ".join(f"{x:.3f}" for x in row) + f" | {np.mean(row):.3f} | " +
              " | ".join(f"{x:.3f}" for x in vrow) + f" | {np.mean(vrow):.3f} | "
              f"{np.mean([res['paper'][lab][n] for n in VAL]):.3f} |")
    with open(os.path.join(a.out, "results.json"), "w", encoding="utf-8") as fh:
        json.dump(res, fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
