"""chain_check_import.py — tests/tools/chain_check.py's check(), importable
from the benches (tests/tools is not a package)."""
import importlib.util
import os

_p = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "tools",
                  "chain_check.py")
_spec = importlib.util.spec_from_file_location("chain_check", _p)
_mod = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_mod)
check = _mod.check
