// Missions have no variables.
package ShortVar

var Drone1 Quadcopter

func INIT() {
	side := 2
	Drone1.FlyByX(side)
}
