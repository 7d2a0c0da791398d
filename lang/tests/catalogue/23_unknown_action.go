// Actions the drone type does not offer.
package UnknownAction

var Drone1 Quadcopter

func INIT() {
	Drone1.FlyBX(1)
	Drone1.Teleport(10)
}
