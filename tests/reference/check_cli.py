# Runs `psub subdivide` and the independent Python reference on one model and compares them.
"""usage: check_cli.py PSUB MODEL LEVELS [extra psub/reference args...]"""
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    psub, model, levels, extra = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
    with tempfile.TemporaryDirectory() as tmp:
        ours, theirs = os.path.join(tmp, 'psub.obj'), os.path.join(tmp, 'reference.obj')
        subprocess.run([psub, 'subdivide', model, '-o', ours, '--levels', levels] + extra, check=True)
        subprocess.run([sys.executable, os.path.join(HERE, 'ps_reference.py'), model, '-o', theirs,
                        '--levels', levels] + extra, check=True)
        return subprocess.run([sys.executable, os.path.join(HERE, 'compare_obj.py'), ours, theirs,
                               '--tol', '1e-5']).returncode


if __name__ == '__main__':
    sys.exit(main())
