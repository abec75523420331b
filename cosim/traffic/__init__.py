"""SUMO traffic: network, demand, the libsumo adapter, V2V."""
