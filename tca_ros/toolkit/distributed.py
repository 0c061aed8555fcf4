"""Batch work on local processes by default, or on an existing Dask cluster.

``run_many(func, items)`` maps a picklable function over items on a Dask
``LocalCluster`` of worker processes (one thread each, as many as cores) with a
text progress bar, and returns the results in order. To use a real cluster,
change one line: pass its scheduler address,

    run_many(func, items, scheduler='tcp://scheduler-host:8786')

or set the environment variable TCA_DASK_SCHEDULER to it. The workers need
tca_ros installed (same version) and the config files their items name.

Ready-made jobs: ``statics_sweep`` (the static stroke of many designs) and
``simulate_batch_distributed`` (the batch simulator, split into chunks of
muscles). Any other batch (calibration or diagnosis of many recordings) is a
``run_many`` over a module-level function of one item.
"""
from contextlib import contextmanager
import os

import numpy as np

SCHEDULER_ENV = 'TCA_DASK_SCHEDULER'  # address of an existing cluster's scheduler


def import_model():
    """Import the physics layer in a worker (a fresh worker spends seconds on SciPy)."""
    import tca_ros.model.dynamics  # noqa: F401
    import tca_ros.model.rod_model  # noqa: F401
    import tca_ros.toolkit.batch  # noqa: F401


@contextmanager
def dask_client(scheduler=None, n_workers=None):
    """Yield a dask.distributed Client: to ``scheduler`` (address), else a local cluster.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler ('tcp://host:8786'); default the
        environment variable TCA_DASK_SCHEDULER, else a LocalCluster.
    n_workers : int, optional
        Worker processes of the local cluster (default: the number of cores).

    Every worker imports the physics layer first (import_model), so the first
    items do not pay for it.
    """
    from dask.distributed import Client, LocalCluster
    address = scheduler or os.environ.get(SCHEDULER_ENV)
    if address:
        client = Client(address)
        try:
            client.run(import_model)
            yield client
        finally:
            client.close()
        return
    workers = int(n_workers or os.cpu_count() or 1)
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.run(import_model)
        yield client


def run_many(func, items, scheduler=None, n_workers=None, progress=True, client=None):
    """Return [func(item) for item in items], computed on a Dask cluster, in order.

    ``client`` reuses an open Client (several batches on one cluster); otherwise one
    is opened as in ``dask_client``. With ``progress`` a text bar is printed. A
    failing item raises RuntimeError naming its index and the error.
    """
    items = list(items)
    if client is None:
        with dask_client(scheduler, n_workers) as own:
            return run_many(func, items, progress=progress, client=own)
    from dask.distributed import progress as progress_bar
    from dask.distributed import wait
    futures = client.map(func, items, pure=False)
    if progress:
        progress_bar(futures, notebook=False)
    wait(futures)
    for index, future in enumerate(futures):
        if future.status == 'error':
            exc = future.exception()
            raise RuntimeError(f'item {index}: {type(exc).__name__}: {exc}') from exc
    return client.gather(futures)


class ExactHelix:
    """The rod model's statics without its dynamics table: the exact helix.

    RodKinetostatics.equilibrium_elongation solves rod_model.helix_elongation; its
    table (built on construction, 1.5 s a design) serves only the dynamics.
    """

    name = 'rod'

    def __init__(self, params):
        if params.coil.shape != 'helix':
            raise ValueError(f'coil.shape = {params.coil.shape!r}: the rod statics of a '
                             'sweep need a helix')
        self.params = params

    def equilibrium_elongation(self, load, temperature, guess=None):
        """Return y (m) with f_rod(y, T) = load (N) at temperature (degC), no contact."""
        from tca_ros.model.rod_model import helix_elongation
        return float(helix_elongation(self.params, temperature, load))


def statics_job(job):
    """Return the static contraction (m) of one design: job = (params, load, temps, model).

    Same as simulation.static_displacement; the rod model through ExactHelix.
    """
    from tca_ros.model.simulation import static_displacement
    params, load, temperatures, model = job
    km = ExactHelix(params) if (model or params.model) == 'rod' else None
    return static_displacement(params, load, temperatures, model=model, kinetostatics=km)


def statics_sweep(designs, load, temperatures, model=None, **cluster):
    """Return (n_designs, n_temperatures) contractions (m) vs temperature (degC).

    ``designs`` are TcaParams; ``load`` (N) is shared; ``cluster`` goes to run_many
    (scheduler, n_workers, progress, client).
    """
    temps = np.asarray(temperatures, dtype=float)
    jobs = [(p, float(load), temps, model) for p in designs]
    return np.array(run_many(statics_job, jobs, **cluster))


def batch_job(job):
    """Return simulate_batch's dict for job = (params_list, time, power, load, model)."""
    from tca_ros.toolkit.batch import simulate_batch
    params_list, time, power, load, model = job
    return simulate_batch(params_list, time, power, load=load, model=model)


def simulate_batch_distributed(params_list, time, power, load=None, model='cst',
                               chunk=1000, **cluster):
    """Run simulate_batch on chunks of ``chunk`` muscles across the cluster; join them.

    ``power`` and ``load`` are (n_samples,) or (N, n_samples) as in simulate_batch.
    """
    params_list = list(params_list)
    n = len(params_list)
    power = np.broadcast_to(np.asarray(power, dtype=float), (n, np.size(time)))
    load = None if load is None else np.broadcast_to(np.asarray(load, dtype=float),
                                                     (n, np.size(time)))
    jobs = [(params_list[i:i + chunk], time, power[i:i + chunk],
             None if load is None else load[i:i + chunk], model)
            for i in range(0, n, chunk)]
    parts = run_many(batch_job, jobs, **cluster)
    return {key: np.concatenate([part[key] for part in parts]) for key in parts[0]}
