"""`tca_sim config new`: write a params file from what a maker knows of a muscle.

The derivations live in tca_ros.model.muscle (docs/describe.md); this module maps
flags to a MuscleSpec, names refused values by their flag, and writes the file with a
header listing what was given and what was derived.
"""
import math
import os

#: MuscleSpec field -> command-line flag, for one-line refusals.
FLAGS = {'thread': '--thread', 'thread_diameter': '--thread-diameter', 'coil': '--coil',
         'mandrel_diameter': '--mandrel-diameter', 'coil_diameter': '--coil-diameter',
         'outer_diameter': '--outer-diameter', 'pitch_angle_deg': '--pitch-angle',
         'coils': '--coils', 'loaded_length': '--loaded-length',
         'natural_length': '--natural-length', 'resistance': '--resistance',
         'break_force': '--break-force',
         'mass': '--mass', 'ambient_degc': '--ambient', 'model': '--model',
         'min_pitch_angle_deg': '--min-pitch-angle', 'inserted_twist': '--inserted-twist',
         'spiral_pitch': '--spiral-pitch', 'cone_angle_deg': '--cone-angle'}

#: Metavariable (the SI unit) shown in ``config new --help`` for each option.
METAVARS = {'out': 'PATH', 'thread': 'PRESET', 'thread_diameter': 'M', 'coil': 'TYPE',
            'mandrel_diameter': 'M', 'coil_diameter': 'M', 'outer_diameter': 'M',
            'pitch_angle': 'DEG', 'coils': 'N', 'loaded_length': 'M', 'natural_length': 'M',
            'resistance': 'OHM', 'break_force': 'N',
            'mass': 'KG', 'ambient': 'DEGC', 'model': 'MODEL',
            'min_pitch_angle': 'DEG', 'inserted_twist': 'RAD_PER_M', 'spiral_pitch': 'M',
            'cone_angle': 'DEG'}


EXAMPLE = """example (a mandrel-coiled silver-plated nylon 6,6 muscle under 10 g):
  tca_sim config new --out my_tca.yaml --thread nylon66_silver --thread-diameter 0.00045 \\
      --coil mandrel --mandrel-diameter 0.0008 --pitch-angle 22.5 --loaded-length 0.14 \\
      --resistance 13.3 --mass 0.01"""


def add_parser(subparsers):
    """Register ``config`` and its ``new`` subcommand on the `tca_sim` subparsers."""
    from tca_ros.model.muscle import COIL_TYPES
    from tca_ros.model.params_schema import MODELS
    sp = subparsers.add_parser(
        'config', help="describe a user's own muscle as a params file",
        description="Describe a user's own muscle as a params file for --config.",
        epilog=EXAMPLE)
    sub = sp.add_subparsers(dest='config_command', metavar='SUBCOMMAND')
    new = sub.add_parser(
        'new', epilog=EXAMPLE,
        help='write a params file from thread, coil, length, resistance and mass',
        description='Write a params file from what a maker knows; everything derivable '
                    '(coil radius, fiber length, coil count, contact angle, inserted twist, '
                    'thermal constants) is derived. SI units; angles in deg. '
                    'See docs/describe.md.')
    new.add_argument('--out', required=True, help='params file (YAML) to write')
    new.add_argument('--force', action='store_true', help='overwrite --out if it exists')
    new.add_argument('--thread', default='nylon66_silver',
                     help='thread preset of config/threads/threads.yaml (nylon66_silver, '
                          'nylon6_monofilament)')
    new.add_argument('--material-from', metavar='CAL.yaml', default=None,
                     help='a params file `tca_sim calibrate` wrote for another muscle of the '
                          'same thread: its calibrated material (Gamma(T), untwist gain, '
                          'moduli, c_p, h, actuation lag) and their uncertainty replace the '
                          "preset's (docs/describe.md)")
    new.add_argument('--thread-diameter', type=float, default=None,
                     help='diameter of the twisted thread, 2 r_t (m)')
    new.add_argument('--coil', default=None,
                     help=f'how the twisted thread was coiled: {", ".join(COIL_TYPES)}')
    new.add_argument('--mandrel-diameter', type=float, default=None,
                     help='mandrel core diameter (m); r* = (mandrel + thread diameter) / 2')
    new.add_argument('--coil-diameter', type=float, default=None,
                     help="mean coil diameter 2 r* (m), the thread's centreline")
    new.add_argument('--outer-diameter', type=float, default=None,
                     help='outer (caliper) coil diameter (m); r* = (outer - thread) / 2')
    new.add_argument('--pitch-angle', type=float, default=None,
                     help='coil pitch angle alpha* (deg)')
    new.add_argument('--coils', type=float, default=None, help='number of coils N (-)')
    new.add_argument('--loaded-length', type=float, default=None,
                     help='length at ambient with --mass hanging (m)')
    new.add_argument('--natural-length', type=float, default=None,
                     help='unloaded length l* at ambient (m); conical: spiral height')
    new.add_argument('--resistance', type=float, default=None,
                     help='resistance R0 at ambient and loaded length (ohm); default: '
                          "the preset's ohm/m x l_t (required for a non-conductive thread)")
    new.add_argument('--break-force', type=float, default=None,
                     help="the thread's measured strength (N); default: the preset's "
                          'breaking stress x the section pi r_t^2')
    new.add_argument('--mass', type=float, default=0.0, help='hanging mass (kg)')
    new.add_argument('--ambient', type=float, default=25.0,
                     help='ambient temperature T0 (degC)')
    new.add_argument('--model', default='rod',
                     help=f'{" | ".join(MODELS)}: kinetostatic model written to the '
                          'file, and used to solve the loaded length')
    new.add_argument('--min-pitch-angle', type=float, default=None,
                     help='measured contact pitch angle alpha_min (deg); default: the '
                          'geometric estimate asin(r_t / (pi r*))')
    new.add_argument('--inserted-twist', type=float, default=None,
                     help='inserted twist theta* (rad/m, = turns/m x 2 pi); default: the '
                          "preset's twist-diameter product / thread diameter")
    new.add_argument('--spiral-pitch', type=float, default=None,
                     help='conical: spiral pitch p_c (m); default 0.0106 (the paper)')
    new.add_argument('--cone-angle', type=float, default=None,
                     help='conical: full cone angle (deg); default 12 (the paper)')
    for action in new._actions:
        if action.dest in METAVARS:
            action.metavar = METAVARS[action.dest]
    new.set_defaults(func=cmd_config_new)
    return sub


def spec_from_args(args):
    """Return the MuscleSpec of parsed ``config new`` arguments."""
    from tca_ros.model.muscle import MuscleSpec
    return MuscleSpec(
        thread=args.thread, thread_diameter=args.thread_diameter, coil=args.coil,
        mandrel_diameter=args.mandrel_diameter, coil_diameter=args.coil_diameter,
        outer_diameter=args.outer_diameter, pitch_angle_deg=args.pitch_angle,
        coils=args.coils, loaded_length=args.loaded_length,
        natural_length=args.natural_length, resistance=args.resistance,
        break_force=args.break_force, mass=args.mass,
        ambient_degc=args.ambient, model=args.model,
        min_pitch_angle_deg=args.min_pitch_angle, inserted_twist=args.inserted_twist,
        spiral_pitch=args.spiral_pitch, cone_angle_deg=args.cone_angle)


def cmd_config_new(args, out):
    """Write the params file of a maker's muscle; print where and the derived figures."""
    from tca_ros.model.muscle import describe_muscle, loaded_length_at_ambient, MuscleError
    from tca_ros.model.params_schema import ParameterError
    from tca_ros.params.files import dump_params, load_params
    from tca_ros.params.thread_presets import load_thread_presets
    if os.path.exists(args.out) and not args.force:
        raise ParameterError(f'--out = {args.out}: exists (use --force to overwrite)')
    spec = spec_from_args(args)
    warnings = []
    try:
        if args.material_from:
            from tca_ros.model.muscle_sibling import describe_from_sibling
            result, warnings = describe_from_sibling(spec, load_thread_presets(),
                                                     _sibling(args.material_from))
        else:
            result = describe_muscle(spec, load_thread_presets())
    except MuscleError as exc:
        raise ParameterError(exc.renamed(FLAGS)) from None
    if warnings:
        from tca_ros.cli.common import warn
        for line in warnings:
            warn('config new', line)
    params = result.params
    derived = dict(result.derived)
    if spec.coil != 'conical':
        if spec.loaded_length is None:
            from tca_ros.model.muscle_spec import Derived
            derived['loaded_length'] = Derived(
                loaded_length_at_ambient(params), 'm',
                f'static length at ambient under the mass ({params.model} model)')
    header = _header(args, spec, result.preset, derived)
    dump_params(params, args.out, header=header)
    load_params(args.out)  # the file must read back through the same schema
    out.write(f'wrote {args.out}\n')
    for name, d in derived.items():
        out.write(f'  {name} = {d.value:.6g} {d.unit}\n')
    return 0


def _sibling(path):
    """Return the params of ``--material-from`` (a calibrated params file)."""
    from tca_ros.cli.common import checked_config
    from tca_ros.model.params_schema import ParameterError
    from tca_ros.params.files import load_params
    if not os.path.isfile(path):
        raise ParameterError(f'--material-from = {path!r}: no such file '
                             '(a params file `tca_sim calibrate` wrote)')
    return load_params(checked_config(path, '--material-from'))


def _header(args, spec, preset, derived):
    """Return the header comment (lines) of a written params file."""
    given = [f'{FLAGS[name]} {value}' for name, value in sorted(vars(spec).items())
             if value is not None and name in FLAGS]
    lines = [
        f'{spec.coil} TCA described by `tca_sim config new`. ROS 2 params file, read by',
        '`ros2 run tca_ros tca_node --ros-args --params-file` and by `tca_sim --config`.',
        'Units: SI; angles in degrees (*_deg), temperatures in degC (*_degc).',
        f'Thread preset {preset.name}: {preset.description}',
        '(properties and their sources: config/threads/threads.yaml; derivations:',
        'docs/describe.md).',
        '',
        'Given (flags, or their defaults):',
    ]
    lines += [f'  {g}' for g in given]
    lines += ['', 'Derived:']
    for name, d in derived.items():
        lines.append(f'  {name} = {_fmt(d.value)} {d.unit}  ({d.note})')
    if args.material_from:
        lines += ['', 'Schema defaults (not derivable from the above): dynamics.damping, '
                  'effects.*,', 'thermal.delivered_power_ratio = 1.',
                  f'Material from the calibrated muscle {args.material_from}: Gamma(T), '
                  'untwist gain, moduli, c_p, h c_s, actuation lag and their uncertainty',
                  '(docs/describe.md, "Another muscle of the same thread").']
    else:
        lines += ['', 'Schema defaults (not derivable from the above): dynamics.damping, '
                  'effects.*,', 'fiber.untwist_gain = 1, thermal.delivered_power_ratio = 1.']
    return '\n'.join(lines)


def _fmt(value):
    return f'{value:.6g}' if isinstance(value, float) and math.isfinite(value) else str(value)
