"""Figure: the diagnosis of real records (docs/fig_real_diagnosis.png).

Two records of the salp mandrel-coiled TCA (../shared/realdata/salp_tca/, 10 g;
skipped when the folder is absent), each diagnosed on its own as
bench_diagnosis_real.py does (rod model, calibrated first on the training
part): the measured contraction, the calibrated nominal model and the extended
model of the diagnosis, with the verdict, what it named, the held-out RMSE and
the held-out spans shaded.

    python bench/plot_real_diagnosis.py [--out docs] [RECORD ...]

Printed figures, not assertions.
"""
import argparse
import os
import sys

from bench_diagnosis_real import _diagnose_real, _length, _mandrel, REAL_DIR
import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402,I100

from tca_ros.diagnosis.plots import shade_heldout  # noqa: E402,I100

DEFAULT = ('encoder_0.8mm_2W_encoder_4.csv', 'encoder_0.8mm_1W_encoder_2.csv')


def main(argv=None):
    """Diagnose the records, draw the figure, print what was found."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('records', nargs='*', default=list(DEFAULT))
    parser.add_argument('--out', default='docs')
    args = parser.parse_args(argv)
    paths = [os.path.join(REAL_DIR, r) if not os.path.isabs(r) else r for r in args.records]
    if not all(os.path.isfile(p) for p in paths):
        print(f'plot_real_diagnosis: records not found under {REAL_DIR}; skipped')
        return 0
    import tempfile
    fig, axes = plt.subplots(len(paths), 1, figsize=(9, 3.2 * len(paths)), squeeze=False)
    with tempfile.TemporaryDirectory() as work:
        for ax, path in zip(axes[:, 0], paths):
            row, result = _diagnose_real(([path], _length(path), work, _mandrel(path)),
                                         keep=True)
            if result is None:
                print(f'{os.path.basename(path)}: {row["verdict"]}')
                continue
            r = result.record
            ax.plot(r.time, r.displacement * 1e3, color='0.45', lw=0.8, label='measured')
            ax.plot(r.time, result.nominal.displacement * 1e3, 'C3',
                    label=f'calibrated nominal ({row["nominal"] * 1e3:.2f} mm)')
            extended = '+'.join(result.effects or result.helpful) or 'nothing added'
            ax.plot(r.time, result.extended.displacement * 1e3, 'C0--',
                    label=f'+ {extended} ({row["extended"] * 1e3:.2f} mm)')
            shade_heldout(ax, result.heldout_spans)
            ax.set_title(f'{os.path.basename(path)}: {result.verdict}'
                         + (f', named {"+".join(result.effects)}' if result.effects else ''),
                         fontsize=10)
            ax.set_ylabel('contraction (mm)')
            ax.legend(fontsize=8, title='held-out RMSE', title_fontsize=8)
            print(f'{os.path.basename(path)}: {result.verdict}; named '
                  f'{result.effects}; helpful {result.helpful}; held-out RMSE '
                  f'{row["nominal"] * 1e3:.2f} -> {row["extended"] * 1e3:.2f} mm; '
                  f'{row["values"]}; {row["cpu"]:.0f} s CPU')
    axes[-1, 0].set_xlabel('time (s); held out where shaded')
    fig.tight_layout()
    os.makedirs(args.out, exist_ok=True)
    out = os.path.join(args.out, 'fig_real_diagnosis.png')
    fig.savefig(out, dpi=90)
    print(f'wrote {out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
