"""Progress bars for long runs (tqdm, from Debian's python3-tqdm); silent with quiet=True."""
from tqdm import tqdm


def progress(total, desc, quiet=False, initial=0):
    return tqdm(total=total, desc=desc, unit="step", disable=quiet, dynamic_ncols=True,
                mininterval=1.0, initial=initial)
