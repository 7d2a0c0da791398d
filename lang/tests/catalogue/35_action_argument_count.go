// Actions called with too few and too many arguments.
package ArgCount

var Drone1 Quadcopter

func INIT() {
	Drone1.Takeoff()
	Drone1.Land(1)
	Drone1.FlyTo(1, 2)
}
