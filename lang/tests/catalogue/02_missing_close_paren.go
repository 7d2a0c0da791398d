// A call is not closed before the end of its line.
package MissingParen

var Drone1 Quadcopter

func INIT() {
	Drone1.Arm()
	Drone1.FlyByX(1
	Drone1.Land()
}
