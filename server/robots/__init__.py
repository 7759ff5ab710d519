"""The robots and who drives them: the fleet, each robot's session, the lease, the driver handles, the consent gate."""
