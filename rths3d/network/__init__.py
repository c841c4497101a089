"""rths3d over the network: the SimApp protocol of OpenSees/OpenFresco (:mod:`.simapp`), the
laboratory server of ``rths3d serve`` (:mod:`.server`) and the wall-clock pacer
(:mod:`.pacing`). The remote transfer system is :mod:`rths3d.transfer.remote`.

This package imports nothing on import: the transfer system imports :mod:`.simapp` and the
server imports the transfer systems, so each module is imported by its own name.
"""
