"""Start FreeTAKServer 2.2.1 (run by the .venv-tak interpreter, so it imports nothing of gcs):
its data package services bind the address fixed in DataPackageServerConstants (0.0.0.0) and some
of its components keep their databases in the fixed MainConfig.PERSISTENCE_PATH (/opt/fts):
both are set here, to loopback and to $FTS_PERSISTENCE_PATH, before FTS's own main runs with
the arguments given."""

import os
import runpy

from FreeTAKServer.core.configuration import DataPackageServerConstants as constants, MainConfig

MainConfig.PERSISTENCE_PATH = os.environ["FTS_PERSISTENCE_PATH"]
_init = constants.DataPackageServerConstants.__init__


def _on_loopback(self):
    _init(self)
    self.IP = "127.0.0.1"


constants.DataPackageServerConstants.__init__ = _on_loopback
runpy.run_module("FreeTAKServer.controllers.services.FTS", run_name="__main__", alter_sys=True)
